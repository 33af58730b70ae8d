"""Renders a result JSON on its target part with FreeCAD (for the README and docs).

Run under a virtual display (see docs): FE_TARGET=part.step FE_RESULT=result.json FE_PNG=out.png \
  QTWEBENGINE_DISABLE_SANDBOX=1 xvfb-run -a -s "-screen 0 1280x1024x24" freecad tools/render_result.py
Each instance's faces get their own color; the rest of the part is grey. Exits the GUI itself.
FE_VIEW=top looks down the z axis (default isometric); FE_FIT=matches fits the view to the
instances' faces instead of the whole part; FE_WIDTH, FE_HEIGHT: the image's size in pixels."""
import json
import os
import sys
import traceback

PALETTE = [(0.89, 0.10, 0.11), (0.22, 0.49, 0.72), (0.30, 0.69, 0.29), (1.00, 0.50, 0.00), (0.60, 0.31, 0.64),
           (0.65, 0.34, 0.16), (0.97, 0.51, 0.75), (0.00, 0.75, 0.75), (0.74, 0.74, 0.13), (0.10, 0.10, 0.55)]


def main():
    import FreeCAD as App
    import FreeCADGui as Gui
    import Part

    target, result, png = os.environ["FE_TARGET"], os.environ["FE_RESULT"], os.environ["FE_PNG"]
    with open(result) as f:
        matches = json.load(f)["matches"]
    doc = App.newDocument("render")
    obj = doc.addObject("Part::Feature", "Target")
    obj.Shape = Part.read(target)
    doc.recompute()
    colors = [(0.75, 0.75, 0.75, 0.0)] * len(obj.Shape.Faces)
    for i, m in enumerate(matches):
        for face in m["faces"]:
            colors[face - 1] = PALETTE[i % len(PALETTE)] + (0.0,)
    obj.ViewObject.DiffuseColor = colors
    view = Gui.ActiveDocument.ActiveView
    getattr(view, {"top": "viewTop", "isometric": "viewIsometric"}[os.environ.get("FE_VIEW", "isometric")])()
    view.fitAll()
    faces = sorted({f for m in matches for f in m["faces"]})
    if os.environ.get("FE_FIT") == "matches" and faces:  # close up on the instances' faces
        fit = doc.addObject("Part::Feature", "Fit")
        fit.Shape = Part.Compound([obj.Shape.Faces[f - 1] for f in faces])
        doc.recompute()
        obj.ViewObject.Visibility = False
        Gui.updateGui()
        view.fitAll()
        obj.ViewObject.Visibility = True
        fit.ViewObject.Visibility = False
    Gui.updateGui()
    view.saveImage(png, int(os.environ.get("FE_WIDTH", "1200")), int(os.environ.get("FE_HEIGHT", "700")), "White")
    print("render_result: wrote", png, "with", len(matches), "instances")


try:
    main()
    code = 0
except Exception:
    traceback.print_exc()
    code = 1
sys.stdout.flush()
os._exit(code)
