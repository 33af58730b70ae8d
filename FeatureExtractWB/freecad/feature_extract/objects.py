"""Document objects of the workbench. Results live in App properties (saved in the .FCStd, available
headless); colors are applied by the view providers, never stored in the model."""
import FreeCAD as App

from . import icon
from .model import quality_color, reference_shape, results_for


class _Stateless:
    """Proxies keep everything in properties: nothing of their own to save or restore.

    FreeCAD 0.20 saves a proxy through __getstate__ (0.21 through dumps). On Python 3.11 every
    object has a __getstate__ that returns its __dict__, and a view provider keeps its Object there:
    "Object of type FeaturePython is not JSON serializable" at every save (issue 11). Both spellings
    say: nothing. Restoring needs nothing either (assigning obj.Proxy while the document is being
    restored is what raised "setAttr failed" on every reopen)."""

    def dumps(self):
        return None

    def loads(self, state):
        return None

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


class ReferenceFeature(_Stateless):
    """A reference feature: a list of faces (FaceN) of a source solid. Its Shape is their compound."""

    Type = "FeatureExtract::ReferenceFeature"

    def __init__(self, obj):
        obj.Proxy = self
        obj.addProperty("App::PropertyLink", "Source", "Reference", "The solid the faces belong to")
        obj.addProperty("App::PropertyStringList", "Faces", "Reference", "Faces of the source, e.g. Face3")

    def execute(self, obj):
        if obj.Source is not None and obj.Faces:
            obj.Shape = reference_shape(obj)


class ExtractionResult(_Stateless):
    """One found instance of a reference on a target (issue 2's result fields)."""

    Type = "FeatureExtract::ExtractionResult"

    def __init__(self, obj):
        obj.Proxy = self
        add = obj.addProperty
        add("App::PropertyLink", "Target", "Result", "The part searched")
        add("App::PropertyLink", "Reference", "Result", "The reference feature searched for")
        add("App::PropertyString", "ReferenceText", "Result", "The reference's label, file path, or 'shape'")
        add("App::PropertyMatrix", "Transform", "Result", "Projective H: reference to target coordinates")
        add("App::PropertyFloat", "Score", "Result", "Fraction of the mapped reference lying on the target")
        add("App::PropertyFloat", "MaxError", "Result", "Acceptance error (quantile of distances), model units")
        add("App::PropertyFloat", "RmsError", "Result", "RMS fit error of the mapped reference, model units")
        add("App::PropertyFloat", "Scale", "Result", "Cube root of the volume ratio of H")
        add("App::PropertyVector", "Center", "Result", "Center of the matched region")
        add("App::PropertyIntegerList", "Faces", "Result", "Matched target faces (FaceN numbers)")
        add("App::PropertyInteger", "Pairs", "Result", "Key point pairs consistent with H")
        add("App::PropertyBool", "Mirrored", "Result", "Found as the mirror image of the reference (H has a negative determinant)")
        add("App::PropertyColor", "Color", "Result", "Color of the matched faces in the 3D view")

    def execute(self, obj):
        pass


class FeatureMesh(_Stateless):
    """A reference feature's FE mesh placed on one found instance (Fem::FemMeshObjectPython: the mesh is
    saved in the .FCStd; the element quality too, so its colors come back on reopening)."""

    Type = "FeatureExtract::FeatureMesh"

    def __init__(self, obj):
        obj.Proxy = self
        add = obj.addProperty
        add("App::PropertyLink", "Target", "Feature mesh", "The part the mesh was placed on")
        add("App::PropertyLink", "Result", "Feature mesh", "The found instance it was placed on")
        add("App::PropertyPath", "FeatureFolder", "Feature mesh", "Reference feature folder (geometry, mesh, specification)")
        add("App::PropertyString", "Specification", "Feature mesh", "Meshing specification, its axis mapped onto this instance")
        add("App::PropertyIntegerList", "ElementIds", "Quality", "Element ids of FemMesh, in the order of ScaledJacobian")
        add("App::PropertyIntegerList", "InpElementIds", "Feature mesh", "The reference mesh's element id of each element")
        add("App::PropertyFloatList", "ScaledJacobian", "Quality", "Scaled Jacobian per element (1 perfect, < 0 inverted)")
        add("App::PropertyFloat", "MinScaledJacobian", "Quality", "Worst element")
        add("App::PropertyInteger", "InvertedElements", "Quality", "Elements inverted by the transfer")
        add("App::PropertyInteger", "UnprojectedNodes", "Quality", "Nodes too far from the target surface to be moved onto it")
        add("App::PropertyStringList", "NodeSets", "Feature mesh", "Named node sets carried from the reference mesh")

    def execute(self, obj):
        pass


class ViewProviderFeatureMesh(_Stateless):
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


class ViewProviderReference(_Stateless):
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


class ViewProviderResult(_Stateless):
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
