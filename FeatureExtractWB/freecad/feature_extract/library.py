"""The feature library in FreeCAD (issue 13), headless: list it, add picked faces to it, search a part
with every feature of it. Works in freecadcmd, macros and the GUI alike.

    from freecad.feature_extract import library
    lib = library.default_library()                      # Resources/library, or the user's choice
    library.add_faces(part, ["Face12", "Face13"], "mounting lug", lib, cls="lug")
    groups = library.search(part, lib)                    # one result group per feature found

Every library operation runs the `featureextract` program (a child process), as `mesh-part` does: a
fault in reading or searching cannot take FreeCAD down, and Cancel kills the child. The document is
changed only by add_results(), in one transaction, after the search succeeded."""
import json
import os
import tempfile

import FreeCAD as App

from . import RESOURCES
from .api import PALETTE, RESULT_GROUP, FeatureExtractError, _changes, run_cli, target_shape

PARAMS = "User parameter:BaseApp/Preferences/Mod/FeatureExtract"
SHIPPED = os.path.join(RESOURCES, "library")


def default_library():
    """The library the commands use: the one last chosen (FreeCAD's preferences), else the shipped one."""
    chosen = App.ParamGet(PARAMS).GetString("Library", "")
    return chosen if chosen and os.path.isdir(chosen) else SHIPPED


def set_default_library(path):
    if not os.path.isdir(path):
        raise FeatureExtractError(f"{path}: not a folder")
    App.ParamGet(PARAMS).SetString("Library", os.path.abspath(path))


def features(library=None):
    """The library's features, as `featureextract library list --json` gives them: name, class, dir,
    hash, rules (text), description, thumbnail (path or None), search."""
    out = run_cli(["library", "list", library or default_library(), "--json"])
    try:
        return json.loads(out)
    except json.JSONDecodeError as e:
        raise FeatureExtractError(f"{library}: the library listing is not readable ({e})")


def face_numbers(source_obj, faces, shape=None):
    """The FaceN names as numbers, each checked against source_obj's faces (one clear sentence if not)."""
    n = len((shape if shape is not None else target_shape(source_obj)).Faces)
    numbers = []
    for f in faces:
        if not (isinstance(f, str) and f.startswith("Face") and f[4:].isdigit()) or not 1 <= int(f[4:]) <= n:
            raise FeatureExtractError(f"{source_obj.Label}: {f!r} is not one of its faces (Face1..Face{n})")
        numbers.append(int(f[4:]))
    return numbers


def add_faces(source_obj, faces, name, library=None, cls="", description="", size=None, progress=None):
    """Adds the faces (["Face3", ...]) of source_obj to the library as a new feature folder (geometry,
    FE mesh by gmsh, feature.json, thumbnail) and returns its path. The document is not changed."""
    library = library or default_library()
    if not name or not name.strip():
        raise FeatureExtractError("a library feature needs a name")
    shape = target_shape(source_obj)
    numbers = face_numbers(source_obj, faces, shape)
    brep = os.path.join(tempfile.mkdtemp(prefix="fe_library_add_"), "part.brep")
    shape.exportBrep(brep)
    cmd = ["library", "add", library, "--from", brep, "--faces", ",".join(map(str, numbers)), "--name", name.strip()]
    if cls:
        cmd += ["--class", cls]
    if description:
        cmd += ["--description", description]
    if size:
        cmd += ["--size", repr(float(size))]
    said = run_cli(cmd, progress).strip().splitlines()  # "featureextract library add: NAME (...) -> FOLDER"
    if not said or " -> " not in said[-1]:
        raise FeatureExtractError(f"{library}: {name!r} was not added")
    return os.path.abspath(said[-1].rsplit(" -> ", 1)[1])


def compute(target_obj, library=None, progress=None, seed=1, shape=None):
    """Searches target_obj for every feature of the library (`featureextract search`, a child
    process) and returns the search result (a dict, the JSON of `featureextract search`). The document
    is not touched, so this may run in the background (pass shape=target_shape(target_obj), taken on
    the GUI thread). progress(stage, fraction) returning False cancels (featureextract.Cancelled)."""
    library = os.path.abspath(library or default_library())
    shape = shape if shape is not None else target_shape(target_obj)
    key = (target_obj.Document.Name, target_obj.Name, shape.hashCode(), library, _library_state(library), int(seed))
    if key in _searched:  # computed in the background, now recorded by the (macro-recordable) search()
        return _searched[key]
    work = tempfile.mkdtemp(prefix="fe_library_search_")
    brep, out = os.path.join(work, "part.brep"), os.path.join(work, "found.json")
    shape.exportBrep(brep)
    run_cli(["search", "--library", library, "--target", brep, "--output", out, "--seed", str(int(seed))],
            _overall(progress) if progress else None)
    with open(out, encoding="utf-8") as f:
        result = json.load(f)
    _searched.clear()  # one search kept: a vault's worth of results must not pile up in FreeCAD
    _searched[key] = result
    return result


_searched = {}


def _library_state(library):
    """What a library's content is, cheaply: its feature folders and their files' times and sizes."""
    state = []
    for d in sorted(os.listdir(library)) if os.path.isdir(library) else []:
        folder = os.path.join(library, d)
        if os.path.isfile(os.path.join(folder, "feature.json")):
            for f in sorted(os.listdir(folder)):
                st = os.stat(os.path.join(folder, f))
                state.append((d, f, st.st_mtime_ns, st.st_size))
    return tuple(state)


def _overall(progress):
    """The search's lines ("NAME (K of N): STAGE", fraction of the stage) as one fraction of the whole
    search that never goes back: each feature gets 1/N of the bar, filled as api.OverallProgress
    fills a single extraction's. Features searched side by side print their lines interleaved: each
    keeps its own bar, and the whole shows the furthest."""
    import re
    from .api import OverallProgress
    state = {"bars": {}, "shown": 0.0}

    def report(stage, fraction):
        m = re.match(r"(.*) \((\d+) of (\d+)\): (.*)$", stage)
        if not m:
            return progress(stage, fraction)
        k, n = int(m.group(2)) - 1, max(1, int(m.group(3)))
        if k not in state["bars"]:
            def shown(s, v, k=k, n=n, name=m.group(1)):
                state["shown"] = max(state["shown"], (k + v) / n)
                return progress(f"{name} ({k + 1} of {n}): {s}", state["shown"])
            state["bars"][k] = OverallProgress(shown)
        return state["bars"][k](m.group(4), fraction)
    return report


def groups_for(target_obj):
    """The per-feature result groups of library searches on target_obj."""
    group = target_obj.Document.getObject(RESULT_GROUP)
    return [o for o in (group.Group if group else []) if o.TypeId == "App::DocumentObjectGroup"
            and getattr(o, "Target", None) == target_obj and hasattr(o, "LibraryFeature")]


def add_results(target_obj, result):
    """Records a library search: for every feature with instances, a group "NAME on PART (N)" of result
    objects, all in the feature's color (replacing the groups of an earlier search of the same part);
    one transaction, and on any error the document is left as it was. Returns the new groups."""
    from . import api
    doc = target_obj.Document
    with _changes(doc, "Search with the feature library") as created:
        top = api.result_group(doc, created)
        old_groups = groups_for(target_obj)
        old = [o for g in old_groups for o in g.Group]
        new_groups = []
        for k, f in enumerate(result["features"]):
            if not f["matches"]:
                continue
            g = doc.addObject("App::DocumentObjectGroup", "LibraryResults")
            created.append(g)
            g.addProperty("App::PropertyLink", "Target", "Library", "The part searched")
            g.addProperty("App::PropertyString", "LibraryFeature", "Library", "The library feature's name")
            g.addProperty("App::PropertyString", "FeatureFolder", "Library", "The feature's folder")
            g.addProperty("App::PropertyString", "Rules", "Library", "The feature's meshing rules")
            g.Target, g.LibraryFeature, g.FeatureFolder = target_obj, f["name"], f["dir"]
            g.Rules = f.get("rules", "")
            objs = api.add_match_objects(target_obj, None, f"library: {f['name']}", f["matches"], created,
                                         color=PALETTE[k % len(PALETTE)])
            top.addObject(g)
            g.Group = objs
            new_groups.append((g, f))
        for o in old:  # only once everything new exists
            doc.removeObject(o.Name)
        for g in old_groups:
            doc.removeObject(g.Name)
        for g, f in new_groups:  # labelled once the old ones are gone (FreeCAD keeps labels unique)
            g.Label = f"{f['name']} on {target_obj.Label} ({len(f['matches'])})"
            for i, (obj, m) in enumerate(zip(g.Group, f["matches"])):
                obj.Label = f"{f['name']} {i + 1} ({m['score']:.2f})"
        doc.recompute()
    if App.GuiUp:
        from .view_providers import recolor
        recolor(target_obj)
    return [g for g, _ in new_groups]


def search(target_obj, library=None, progress=None, seed=1):
    """Searches target_obj with the whole library and records the result (add_results). Returns the
    new groups, one per feature found."""
    return add_results(target_obj, compute(target_obj, library, progress, seed))


def summary(result):
    """One line per feature for the report view: found, not searched (and why), overlaps."""
    lines = []
    for f in result["features"]:
        if f.get("error"):
            lines.append(f"{f['name']}: not searched ({f['error']})")
        else:
            lines.append(f"{f['name']}: {len(f['matches'])} found")
    for o in result.get("overlaps", []):
        claims = ", ".join(f"{c['feature']} #{c['match'] + 1} ({c['score']:.2f})" for c in o["claims"])
        lines.append(f"faces {o['faces'][:6]}{'...' if len(o['faces']) > 6 else ''} claimed by {claims}; the first is kept")
    return lines
