"""The workbench's document objects, App side only (they work in freecadcmd, no FreeCADGui here):
ReferenceFeature (faces of a source solid), ExtractionResult (one found instance), FeatureMesh (an FE
mesh placed on one). Results live in App properties (saved in the .FCStd, available headless); each
proxy's `Type` names its kind for model.is_of_type. How they look (view providers, face and element
colors, selecting a result's faces) is in view_providers.

Documents saved before the view providers moved out of this module (issue 11, layout by role) name
them as freecad.feature_extract.objects.ViewProvider*: FreeCAD 0.20 restores a proxy by importing
the module its GuiDocument.xml names and taking the class from it by name. `__getattr__` below
(PEP 562) answers those names from view_providers when asked, so those documents open as before,
and importing this module imports nothing of the GUI."""
from .model import Stateless, reference_shape

# the names earlier versions saved in GuiDocument.xml, resolved lazily (FreeCAD asks only with a GUI)
_MOVED_TO_VIEW_PROVIDERS = ("ViewProviderReference", "ViewProviderResult", "ViewProviderFeatureMesh")


def __getattr__(name):
    if name in _MOVED_TO_VIEW_PROVIDERS:
        from . import view_providers
        return getattr(view_providers, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class ReferenceFeature(Stateless):
    """A reference feature: a list of faces (FaceN) of a source solid. Its Shape is their compound."""

    Type = "FeatureExtract::ReferenceFeature"

    def __init__(self, obj):
        obj.Proxy = self
        obj.addProperty("App::PropertyLink", "Source", "Reference", "The solid the faces belong to")
        obj.addProperty("App::PropertyStringList", "Faces", "Reference", "Faces of the source, e.g. Face3")

    def execute(self, obj):
        if obj.Source is not None and obj.Faces:
            obj.Shape = reference_shape(obj)


class ExtractionResult(Stateless):
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


class FeatureMesh(Stateless):
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
