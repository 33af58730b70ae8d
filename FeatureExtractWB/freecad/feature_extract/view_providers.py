"""How the workbench's document objects look, GUI side: their view providers (ViewProviderReference,
ViewProviderResult, ViewProviderFeatureMesh) and what they do on the 3D view: the results' face colors
on a part (recolor, clear_colors), the FE meshes' element colors by quality (color_by_quality),
selecting a result's faces (select_faces). They read the objects through their properties only, never
their classes, and import FreeCADGui, PySide and pivy only where they use them, so that importing this
module needs no GUI (objects answers the view provider names of older documents from here)."""
import FreeCAD as App

from . import icon
from .model import Stateless, quality_color, results_for


class ViewProviderFeatureMesh(Stateless):
    """Colors the elements by quality (green good, yellow fair, orange poor, red inverted)."""

    def __init__(self, vobj):
        vobj.Proxy = self
        try:
            vobj.DisplayMode = "Faces & Wireframe"  # node dots would hide the quality colors
        except Exception:  # noqa: BLE001
            pass

    def attach(self, vobj):
        self.Object = vobj.Object
        from PySide import QtCore
        QtCore.QTimer.singleShot(0, lambda: color_by_quality(vobj.Object))

    def getIcon(self):
        return icon("PlaceMesh")

    def updateData(self, obj, prop):
        if prop in ("ScaledJacobian", "FemMesh"):
            color_by_quality(obj)


def color_by_quality(obj):
    """Element colors from the stored quality (deferred callers: the view provider must exist)."""
    vo = getattr(obj, "ViewObject", None)
    if vo is None or not obj.ElementIds or len(obj.ElementIds) != len(obj.ScaledJacobian):
        return False
    try:
        vo.ElementColor = {int(e): quality_color(q) for e, q in zip(obj.ElementIds, obj.ScaledJacobian)}
    except Exception:  # noqa: BLE001  (an older FemGui without ElementColor: plain mesh color)
        return False
    return True


def _same_colors(have, want):
    """Colors equal to 8 bits a channel (as the document stores them), lists or {id: color} dicts."""
    if isinstance(want, dict):
        if not isinstance(have, dict) or set(have) != set(want):
            return False
        have, want = [have[k] for k in sorted(have)], [want[k] for k in sorted(want)]
    have, want = list(have), list(want)
    return len(have) == len(want) and all(abs(a - b) <= 1.5 / 255 for x, y in zip(have, want) for a, b in zip(x[:3], y[:3]))


def face_names(result_obj):
    return [f"Face{f}" for f in result_obj.Faces]


def recolor(target_obj):
    """Colors the target's faces: every result on it in its own color, the rest in the shape color.
    Where results claim the same face, the best scored shows (ties: the first by reference name, as
    a library search ranks its overlaps). Deferred to the event loop: a DiffuseColor set inside a
    recompute is overwritten afterwards."""
    if not App.GuiUp or target_obj is None:
        return
    from PySide import QtCore

    def apply():
        vo = getattr(target_obj, "ViewObject", None)
        if vo is None:
            return
        n = len(target_obj.Shape.Faces)
        base = tuple(vo.ShapeColor[:3]) + (0.0,)
        colors = [base] * n
        ranked = sorted(results_for(target_obj), key=lambda r: (-round(r.Score, 6), r.ReferenceText, r.Label))
        for r in reversed(ranked):  # the best last, so that it shows
            if getattr(r, "ViewObject", None) is not None and not r.ViewObject.Visibility:
                continue
            for f in r.Faces:
                if 1 <= f <= n:
                    colors[f - 1] = tuple(r.Color[:3]) + (0.0,)
        if not _same_colors(vo.DiffuseColor, colors):  # setting the same colors would mark the document modified
            vo.DiffuseColor = colors

    QtCore.QTimer.singleShot(0, apply)


def clear_colors(target_obj):
    vo = getattr(target_obj, "ViewObject", None)
    if vo is not None:
        vo.DiffuseColor = [tuple(vo.ShapeColor[:3]) + (0.0,)] * len(target_obj.Shape.Faces)


class ViewProviderReference(Stateless):
    def __init__(self, vobj):
        vobj.Proxy = self
        vobj.ShapeColor = (1.0, 0.85, 0.0)
        vobj.Transparency = 40
        # it lies exactly on the source's faces: hidden by default so that it does not mask the
        # result colors there (space bar shows it)
        vobj.Visibility = False

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return icon("PickReference")


class ViewProviderResult(Stateless):
    """Shows a result as colored faces on its target; hiding it removes its color."""

    def __init__(self, vobj):
        vobj.Proxy = self

    def attach(self, vobj):
        self.Object = vobj.Object
        # the "Default" display mode must exist as a node: without one FreeCAD takes the object for
        # hidden and greys it in the tree, though its Visibility is True (its look is the target's
        # face colors, so the node is empty)
        from pivy import coin
        vobj.addDisplayMode(coin.SoGroup(), "Default")

    def getIcon(self):
        return icon("Extract")

    def getDisplayModes(self, vobj):
        return ["Default"]

    def getDefaultDisplayMode(self):
        return "Default"

    def updateData(self, obj, prop):
        if prop in ("Faces", "Color", "Target"):
            recolor(obj.Target)

    def onChanged(self, vobj, prop):
        if prop == "Visibility":
            recolor(vobj.Object.Target)

    def onDelete(self, vobj, subelements):
        target = vobj.Object.Target
        from PySide import QtCore
        QtCore.QTimer.singleShot(0, lambda: recolor(target) if target and target.Document else None)
        return True

    def doubleClicked(self, vobj):
        select_faces(vobj.Object)
        return True


def select_faces(result_obj):
    """Selects the result's faces on its target in the 3D view."""
    import FreeCADGui as Gui
    target = result_obj.Target
    if target is None:
        return
    Gui.Selection.clearSelection()
    Gui.Selection.addSelection(target, face_names(result_obj))
