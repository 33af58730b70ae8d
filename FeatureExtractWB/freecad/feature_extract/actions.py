"""What the GUI does for the user, below the commands and the task panels (both call it, it imports
neither): say a failure in one sentence, run and record an API call, read the selection, run work in
the background with its outcome said, and the library's two actions (add the picked faces, search
a part), which the toolbar commands and the library panel share."""
import FreeCAD as App
import FreeCADGui as Gui

from . import background, translate
from .model import is_of_type, target_shape

INTERACTIVE = True  # False in tests: errors go to the report view only (no modal dialog)
last_error = None


def report_error(message):
    """A clear message for the user: a dialog and the report view; never a traceback."""
    global last_error
    last_error = message
    App.Console.PrintError("FeatureExtract: " + message + "\n")
    if INTERACTIVE:
        from PySide import QtGui
        QtGui.QMessageBox.warning(Gui.getMainWindow(), translate("FeatureExtract", "FeatureExtract"), message)


def do(command, module="freecad.feature_extract.api"):
    """Runs (and records for macros) one API call; a failure becomes a message, not a traceback."""
    # the import is recorded every time: Gui.addModule writes it once per session, so a macro
    # recorded after the first use would lack it and stop with "name 'freecad' is not defined"
    Gui.doCommand(f"import {module}")
    try:
        Gui.doCommand(command)
    except Exception as e:  # noqa: BLE001
        report_error(str(e))


def selected_solid():
    sel = Gui.Selection.getSelectionEx()
    for s in sel:
        shape = getattr(s.Object, "Shape", None)
        if shape is not None and not shape.isNull() and shape.Faces and \
                not is_of_type(s.Object, "ReferenceFeature"):
            return s.Object
    return None


def only_solid(doc):
    """The document's one visible solid, when there is exactly one (the "active part")."""
    if doc is None:
        return None
    solids = [o for o in doc.Objects if (o.TypeId.startswith("Part::") or o.TypeId == "PartDesign::Body") and getattr(o, "Shape", None) is not None
              and not o.Shape.isNull() and o.Shape.Solids and getattr(o, "Visibility", True)]
    return solids[0] if len(solids) == 1 else None


def references(doc):
    return [o for o in doc.Objects if is_of_type(o, "ReferenceFeature")]


def picked_faces():
    """(solid, ["Face3", ...]) of the faces selected on one solid, or a message saying what is wrong."""
    sel = [s for s in Gui.Selection.getSelectionEx() if s.SubElementNames]
    if not sel:
        return None, translate("FeatureExtract", "Select one or more faces of a solid first.")
    if len({s.Object.Name for s in sel}) > 1:
        return None, translate("FeatureExtract", "Select faces of one solid only.")
    names = [n for s in sel for n in s.SubElementNames]
    bad = [n for n in names if not n.startswith("Face")]
    if bad:
        return None, translate("FeatureExtract", "Only faces can make a feature; the selection has ") + ", ".join(bad)
    return sel[0].Object, names


def start(title, label, work, on_ok, cancelled="the document was not changed", done=None):
    """Runs work(progress) in the background (background.py); then, on the GUI thread, on_ok(value)
    when it succeeded, a message when it failed or was cancelled, and done(kind, value) if given."""

    def finished(kind, value):
        if kind == "ok":
            on_ok(value)
        elif kind == "error":
            report_error(value)
        else:
            App.Console.PrintMessage(f"FeatureExtract: cancelled; {cancelled}.\n")
        if done is not None:
            done(kind, value)

    return background.start(title, label, work, finished)


def add_picked_faces(name=None, cls="", description="", lib=None, done=None):
    """The faces picked on a solid become a new feature of the library (`featureextract library add`
    in the background). Without a name, the user is asked for one. A refusal is said before anything
    starts (then background.running stays None)."""
    from . import library
    obj, faces = picked_faces()
    if obj is None:
        report_error(faces)
        return
    lib = lib or library.default_library()
    if name is None:
        from PySide import QtGui
        name, ok = QtGui.QInputDialog.getText(Gui.getMainWindow(), translate("FeatureExtract", "Add to the library"),
                                              translate("FeatureExtract", "Name of the new feature ({n} faces of {part}):")
                                              .format(n=len(faces), part=obj.Label))
        if not ok:
            return
    if not name.strip():
        report_error(translate("FeatureExtract", "A library feature needs a name."))
        return
    try:
        library.face_numbers(obj, faces)  # a bad selection is said now, not after the child ran
    except Exception as e:  # noqa: BLE001
        report_error(str(e))
        return

    def added(folder):
        App.Console.PrintMessage(f"FeatureExtract: {name.strip()} ({len(faces)} faces of {obj.Label}) added to "
                                 f"the library {lib} as {folder}\n")

    start(translate("FeatureExtract", "Add picked faces to the library"),
          translate("FeatureExtract", "Meshing {name} for the library...").format(name=name.strip()),
          lambda progress: library.add_faces(obj, faces, name, lib, cls, description, progress=progress), added,
          cancelled="nothing was added", done=done)


def search_part(lib=None, done=None):
    """Searches the selected solid (or the document's only one) for every feature of the library in
    the background, then records one result group per feature found by a recorded
    `library.search(...)` call."""
    from . import library
    target = selected_solid() or only_solid(App.ActiveDocument)
    if target is None:
        report_error(translate("FeatureExtract", "Select the solid to search."))
        return
    lib = lib or library.default_library()
    try:
        shape = target_shape(target)
        names = [f["name"] for f in library.features(lib)]
    except Exception as e:  # noqa: BLE001
        report_error(str(e))
        return

    def searched(result):
        do(f"freecad.feature_extract.library.search(App.getDocument('{target.Document.Name}')"
           f".getObject('{target.Name}'), {lib!r})", module="freecad.feature_extract.library")
        for line in library.summary(result):
            App.Console.PrintMessage(f"FeatureExtract: {target.Label}: {line}\n")

    start(translate("FeatureExtract", "Search the part with the library"),
          translate("FeatureExtract", "Searching {name} for {n} features...").format(name=target.Label, n=len(names)),
          lambda progress: library.compute(target, lib, progress=progress, shape=shape), searched, done=done)
