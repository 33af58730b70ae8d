"""What the workbench keeps in a document and how to read it, with no GUI and no C++ core: the
results group, the one type test of its objects, the proxy base that saves nothing (document objects
and view providers both derive from it), a reference's faces as a shape, the results and meshes on a
part, and the quality colors. The lowest layer of the package: view_providers, objects, the headless
api and the GUI all import it, and it imports none of them."""

RESULT_GROUP = "FeatureExtractResults"


class FeatureExtractError(ValueError):
    """A problem the user can fix (bad selection, no solid, unreadable shape): one clear sentence."""


class Stateless:
    """The base of every proxy, document objects' and view providers' alike: they keep everything in
    properties, nothing of their own to save or restore.

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


def is_of_type(obj, name):
    """True when obj is one of the workbench's document objects of that kind ("ReferenceFeature",
    "ExtractionResult", "FeatureMesh"): its proxy's Type, which a reopened document keeps too."""
    return getattr(getattr(obj, "Proxy", None), "Type", None) == "FeatureExtract::" + name


def shape_of(obj):
    shape = getattr(obj, "Shape", None)
    if shape is None or shape.isNull():
        raise FeatureExtractError(f"{obj.Label}: has no shape")
    return shape


def target_shape(obj):
    """The solid(s) of a target object; a shape without faces is refused."""
    shape = shape_of(obj)
    if not shape.Faces:
        raise FeatureExtractError(f"{obj.Label}: has no faces to search")
    return shape


def reference_shape(ref_obj):
    """The faces of a reference feature as one compound (FaceN of its source, in the order given)."""
    src = ref_obj.Source
    if src is None:
        raise FeatureExtractError(f"{ref_obj.Label}: its source object is gone")
    shape = shape_of(src)
    faces = []
    for name in ref_obj.Faces:
        if not name.startswith("Face"):
            raise FeatureExtractError(f"{ref_obj.Label}: '{name}' is not a face")
        try:
            faces.append(shape.getElement(name))
        except Exception:
            raise FeatureExtractError(f"{ref_obj.Label}: {src.Label} has no {name}")
    if not faces:
        raise FeatureExtractError(f"{ref_obj.Label}: no faces")
    import Part
    return Part.makeCompound(faces)


def results_for(target_obj):
    """The found instances (result objects) on target_obj."""
    group = target_obj.Document.getObject(RESULT_GROUP)
    members = []
    for o in (group.Group if group else []):  # a library search's results sit in one group per feature
        members += list(o.Group) if o.TypeId == "App::DocumentObjectGroup" else [o]
    return [o for o in members if getattr(o, "Target", None) == target_obj
            and is_of_type(o, "ExtractionResult")]


def meshes_for(target_obj):
    """The FE meshes placed on target_obj."""
    group = target_obj.Document.getObject(RESULT_GROUP)
    return [o for o in (group.Group if group else []) if getattr(o, "Target", None) == target_obj
            and is_of_type(o, "FeatureMesh")]


def quality_color(sj):
    """Element color by scaled Jacobian: green (good) through yellow and orange to red (inverted)."""
    if sj < 0:
        return (0.85, 0.0, 0.0)
    if sj < 0.3:
        return (1.0, 0.45, 0.0)
    if sj < 0.6:
        return (1.0, 0.85, 0.0)
    return (0.2, 0.75, 0.25)
