"""Places a reference feature folder's FE mesh on a part with the workbench and renders it (README).

Run under a virtual display: FE_TARGET=part.step FE_FEATURE=Resources/library/rib FE_PNG=out.png \
  [FE_ZOOM=1.6] QTWEBENGINE_DISABLE_SANDBOX=1 xvfb-run -a -s "-screen 0 1280x1024x24" freecad tools/render_meshes.py
The part is drawn grey and half transparent, the meshes colored by element quality. Exits the GUI itself."""
import os
import sys
import traceback


def main():
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, os.path.join(here, "FeatureExtractWB"))
    import freecad
    if os.path.join(here, "FeatureExtractWB", "freecad") not in freecad.__path__:
        freecad.__path__.append(os.path.join(here, "FeatureExtractWB", "freecad"))
    import FreeCAD as App
    import FreeCADGui as Gui
    import Part
    from PySide import QtGui
    from freecad.feature_extract import api

    doc = App.newDocument("render")
    part = doc.addObject("Part::Feature", "Part")
    part.Shape = Part.read(os.environ["FE_TARGET"])
    doc.recompute()
    meshes = api.place_meshes(part, os.environ["FE_FEATURE"], seed=1)
    part.ViewObject.ShapeColor = (0.8, 0.8, 0.8)
    part.ViewObject.Transparency = 50
    for _ in range(20):
        QtGui.QApplication.processEvents()
    if os.environ.get("FE_HIDE_PART"):
        part.ViewObject.Visibility = False
    Gui.getMainWindow().showMaximized()
    view = Gui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    zoom = float(os.environ.get("FE_ZOOM", "1"))
    if zoom != 1:
        cam = view.getCameraNode()
        cam.height.setValue(cam.height.getValue() / zoom)
    for _ in range(20):
        QtGui.QApplication.processEvents()
    view.saveImage(os.environ["FE_PNG"], 1200, 700, "White")
    print(f"render_meshes: {len(meshes)} meshes -> {os.environ['FE_PNG']}")


try:
    main()
except Exception:
    traceback.print_exc()
sys.stdout.flush()
os._exit(0)
