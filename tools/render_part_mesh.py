"""Renders a whole-part mesh (featureextract mesh-part's part.inp) in FreeCAD: each instance's patch in its
own color, the rest grey, element edges drawn (the README's picture).

Run under a virtual display: FE_INP=OUT/part.inp FE_PNG=out.png [FE_ZOOM=1.4] QTWEBENGINE_DISABLE_SANDBOX=1 \\
  FEATUREEXTRACT_PYTHONPATH=build/python xvfb-run -a -s "-screen 0 1280x1024x24" freecad tools/render_part_mesh.py
Exits the GUI itself."""
import os
import sys
import traceback

PALETTE = [(0.90, 0.30, 0.20), (0.20, 0.55, 0.90), (0.95, 0.70, 0.10), (0.30, 0.75, 0.35), (0.65, 0.35, 0.85),
           (0.10, 0.75, 0.75), (0.85, 0.45, 0.65), (0.55, 0.45, 0.20)]


def main():
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, os.path.join(here, "FeatureExtractWB"))
    if os.environ.get("FEATUREEXTRACT_PYTHONPATH"):
        sys.path.insert(0, os.environ["FEATUREEXTRACT_PYTHONPATH"])
    import freecad
    if os.path.join(here, "FeatureExtractWB", "freecad") not in freecad.__path__:
        freecad.__path__.append(os.path.join(here, "FeatureExtractWB", "freecad"))
    import FreeCAD as App
    import FreeCADGui as Gui
    from PySide import QtGui
    import featureextract as fx
    from freecad.feature_extract import api

    mesh = fx.read_fe_mesh(os.environ["FE_INP"])
    doc = App.newDocument("render")
    obj = doc.addObject("Fem::FemMeshObject", "PartMesh")
    femmesh, _ = api._fem_mesh(mesh)
    obj.FemMesh = femmesh
    doc.recompute()
    # element -> color: the instance sets (NAME_k, no further underscore-suffix set) in turn, the rest grey
    sets = mesh.element_sets
    instances = sorted(n for n in sets if n != "PART_REST" and not any(
        n != m and n.startswith(m + "_") for m in sets))
    colors = {}
    for k, name in enumerate(instances):
        for e in sets[name]:
            colors[int(e) + 1] = PALETTE[k % len(PALETTE)]
    n = sum(len(b[1]) for b in mesh.blocks)
    for e in range(1, n + 1):
        colors.setdefault(e, (0.82, 0.82, 0.82))
    vo = obj.ViewObject
    vo.DisplayMode = "Faces & Wireframe"
    vo.ElementColor = colors
    for _ in range(20):
        QtGui.QApplication.processEvents()
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
    print(f"render_part_mesh: {len(instances)} instances -> {os.environ['FE_PNG']}")


try:
    main()
except Exception:
    traceback.print_exc()
sys.stdout.flush()
os._exit(0)
