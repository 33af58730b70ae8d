"""Headless API of the FeatureExtract workbench: works in freecadcmd, macros and the GUI alike.

    import FreeCAD as App
    from freecad.feature_extract import api
    doc = App.openDocument("part.FCStd")          # or App.newDocument() + Part.read(...)
    part = doc.getObject("Part")
    ref = api.make_reference(part, ["Face12", "Face13", "Face14"])
    results = api.extract(part, ref, seed=1)       # one FeatureExtractResult per instance
    for r in results:
        print(r.Label, r.Score, r.Faces)

Every document change happens in one transaction after the computation succeeded; on any error the
document is left exactly as it was (nothing is created, recolored or removed)."""
import FreeCAD as App

from . import translate  # noqa: F401  (also sets up sys.path for the native module)
# the api's own names too (api.results_for, api.FeatureExtractError, ...), for macros and scripts
from .model import RESULT_GROUP, FeatureExtractError, is_of_type, meshes_for, reference_shape, results_for, shape_of, target_shape

import featureextract as fx

PALETTE = [(0.89, 0.10, 0.11), (0.22, 0.49, 0.72), (0.30, 0.69, 0.29), (1.00, 0.50, 0.00), (0.60, 0.31, 0.64),
           (0.65, 0.34, 0.16), (0.97, 0.51, 0.75), (0.00, 0.75, 0.75), (0.74, 0.74, 0.13), (0.10, 0.10, 0.55)]


class _changes:
    """One undoable transaction that also holds without an undo stack (freecadcmd has UndoMode 0, where
    abortTransaction undoes nothing): on an exception the objects listed in `created` are removed
    again, so a failed call leaves the document as it was."""

    def __init__(self, doc, name):
        self.doc, self.name, self.created = doc, name, []

    def __enter__(self):
        self.doc.openTransaction(self.name)
        return self.created

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.doc.commitTransaction()
            return False
        for obj in reversed(self.created):
            try:
                if self.doc.getObject(obj.Name) is not None:
                    self.doc.removeObject(obj.Name)
            except Exception:  # noqa: BLE001  (already gone)
                pass
        self.doc.abortTransaction()
        return False


# ---------------------------------------------------------------------------------------------
# shapes -> core meshes

def mesh_of_shape(shape, name, feature_size=None):
    """Tessellates a Part.Shape through its BREP text, so the core's faces are FreeCAD's FaceN."""
    if feature_size:
        rel, absolute = fx.tessellation_for_feature(feature_size)
        return fx.read_brep_string(shape.exportBrepToString(), name, rel, absolute)
    return fx.read_brep_string(shape.exportBrepToString(), name)


# ---------------------------------------------------------------------------------------------
# reference features

def _one_plane(faces, size):
    """Do all these faces lie in one plane?"""
    import Part
    ref = None
    for face in faces:
        surf = face.Surface
        if not isinstance(surf, Part.Plane):
            return False
        if ref is None:
            ref = surf
            continue
        if ref.Axis.cross(surf.Axis).Length > 1e-6 or abs((surf.Position - ref.Position).dot(ref.Axis)) > 1e-6 * size:
            return False
    return ref is not None


def make_reference(source, faces, label="Reference"):
    """Creates a persistent Reference feature from faces of `source` (names like 'Face3')."""
    from .objects import ReferenceFeature
    if not isinstance(source, App.DocumentObject):
        raise FeatureExtractError(f"{source!r}: a reference needs a document object with faces as its source")
    faces = list(faces)
    if not faces:
        raise FeatureExtractError(translate("FeatureExtract", "Select one or more faces of a solid first."))
    bad = [f for f in faces if not f.startswith("Face")]
    if bad:
        raise FeatureExtractError(f"{source.Label}: only faces can make a reference, not {', '.join(bad)}")
    shape = shape_of(source)
    for f in faces:
        try:
            shape.getElement(f)
        except Exception:
            raise FeatureExtractError(f"{source.Label}: has no {f}")
    if _one_plane([shape.getElement(f) for f in faces], shape.BoundBox.DiagonalLength):
        # said at pick time, in an analyst's words: the engine would refuse it only after a run
        raise FeatureExtractError(translate(
            "FeatureExtract", "{0}: the picked faces lie in one flat plane, and a flat patch has no shape of its own to "
                              "look for. Pick the faces of the feature itself: its walls, fillets and top, or a hole's wall.")
            .format(source.Label))
    doc = source.Document
    with _changes(doc, "Make reference feature") as created:
        obj = doc.addObject("Part::FeaturePython", label)
        created.append(obj)
        ReferenceFeature(obj)
        obj.Source = source
        obj.Faces = faces
        if App.GuiUp:
            from .view_providers import ViewProviderReference
            ViewProviderReference(obj.ViewObject)
        doc.recompute()
    return obj


def save_reference(ref_obj, path):
    """Writes a reference feature's faces as a BREP file (reusable with read_shape / the CLI)."""
    reference_shape(ref_obj).exportBrep(path)
    return path


# ---------------------------------------------------------------------------------------------
# extraction

_cache = {}  # key -> (fx.Result, target Mesh) of recent runs, so that extract() right after does not recompute
_CACHE_SIZE = 4


def _key(target_obj, reference, params):
    ref_key = reference if isinstance(reference, str) else getattr(reference, "Name", id(reference))
    ref_faces = tuple(getattr(reference, "Faces", ()))
    return (target_obj.Document.Name, target_obj.Name, target_shape(target_obj).hashCode(), ref_key, ref_faces,
            params.to_json())


class Job:
    """Everything an extraction needs, taken from the document in the main thread; run() then needs
    no document access and can go to a worker thread."""

    def __init__(self, target_obj, reference, **params):
        self.params = fx.make_params(**params)
        self.key = _key(target_obj, reference, self.params)
        self.reference = reference if isinstance(reference, str) else None
        self.reference_brep = None
        self.reference_label = "reference"
        if self.reference is None:
            if hasattr(reference, "isNull"):
                self.reference_brep = reference.exportBrepToString()
            elif is_of_type(reference, "ReferenceFeature"):
                self.reference_brep = reference_shape(reference).exportBrepToString()
                self.reference_label = reference.Label
            else:
                raise FeatureExtractError(f"{getattr(reference, 'Label', reference)}: not a reference feature")
        self.target_brep = target_shape(target_obj).exportBrepToString()
        self.target_label = target_obj.Label


def prepare(target_obj, reference, **params):
    return Job(target_obj, reference, **params)


# Share of an extraction's time per stage of the core (NIST CTC-02 with a lug: target SHOT 4.2 s and
# RANSAC 7.7 s of 15 s), in the order the core reports them.
_STAGE_SHARE = [("tessellating", 0.04), ("reference", 0.03), ("target: sampling", 0.06), ("target: normals", 0.06),
                ("target: shape index", 0.04), ("target: SHOT", 0.25), ("target: regions", 0.01), ("pairs", 0.05),
                ("clusters", 0.01), ("ransac", 0.42), ("topology", 0.02), ("result", 0.01)]


class OverallProgress:
    """Turns the core's per-stage reports (stage, fraction of that stage) into one fraction of the
    whole run that never goes back, for a progress bar: calls report(stage, overall) and returns
    what it returns (False cancels). A stage earlier than the last one (the mirror image's pass, the
    ridge-and-rut fallback) starts a new pass in the rest of the bar."""

    def __init__(self, report):
        self.report = report
        self.value = 0.0
        self.base, self.span, self.last = 0.0, 1.0, -1

    def __call__(self, stage, fraction):
        k = next((i for i, (name, _) in enumerate(_STAGE_SHARE) if stage.startswith(name)), None)
        if stage == "done":
            self.value = 1.0
        elif k is not None:
            if k < self.last:  # a new pass: it gets most of what is left of the bar
                self.base, self.span = self.value, 0.8 * (1.0 - self.value)
            self.last = k
            before = sum(w for _, w in _STAGE_SHARE[:k])
            f = min(max(float(fraction), 0.0), 1.0)
            self.value = max(self.value, self.base + self.span * (before + _STAGE_SHARE[k][1] * f))
        return self.report(stage, self.value)


def run(job, progress=None):
    """The computation of a Job (core only; releases the GIL). The result is cached for extract(), and
    the target mesh it was found on is kept in job.target_mesh (mesh transfer projects onto it).
    progress(stage, fraction) gets the fraction of the whole run (OverallProgress)."""
    if progress is not None:
        progress = OverallProgress(progress)
        if progress("tessellating", 0.0) is False:
            raise fx.Cancelled("cancelled")
    if job.reference is not None:
        ref = fx.read_shape(job.reference)
    else:
        ref = fx.read_brep_string(job.reference_brep, job.reference_label)
    rel, absolute = fx.tessellation_for_feature(ref.diagonal)
    tgt = fx.read_brep_string(job.target_brep, job.target_label, rel, absolute)
    if progress is not None and progress("tessellating", 1.0) is False:
        raise fx.Cancelled("cancelled")
    result = fx.extract(ref, tgt, job.params, progress)
    job.target_mesh = tgt
    _cache[job.key] = (result, tgt)
    while len(_cache) > _CACHE_SIZE:
        _cache.pop(next(iter(_cache)))
    return result


def compute(target_obj, reference, progress=None, **params):
    """Runs the extraction without touching the document; returns the core's Result (cached, so an
    immediately following extract() with the same arguments does not compute again)."""
    return run(prepare(target_obj, reference, **params), progress)


def extract(target_obj, reference, progress=None, **params):
    """Finds the instances of `reference` (a reference feature object, a Part.Shape or a file path) on
    `target_obj` and records one FeatureExtractResult object per instance in the document's result
    group (previous results for the same target and reference are replaced). Returns them."""
    result, _ = _computed(prepare(target_obj, reference, **params), progress)
    return add_results(target_obj, reference, result)


def _computed(job, progress=None):
    """(result, target mesh) of a job: taken from the cache when the GUI has just computed it, else
    computed now."""
    cached = _cache.pop(job.key, None)
    if cached is not None:
        return cached
    result = run(job, progress)
    _cache.pop(job.key, None)
    return result, job.target_mesh


def _reference_link(reference):
    """(object to link, text) for a reference: a document object is linked; a file path or a Part.Shape
    cannot be, and is described in ReferenceText instead."""
    if isinstance(reference, App.DocumentObject):
        return reference, reference.Label
    if isinstance(reference, str):
        return None, reference
    return None, "shape"


def _field(m, key):
    """A match's field: a core Match's attribute, or a key of a result JSON's match."""
    return m[key] if isinstance(m, dict) else getattr(m, key)


def add_match_objects(target_obj, ref_obj, ref_text, matches, created, color=None):
    """One FeatureExtractResult object per match (core Matches or result JSON dicts), appended to
    `created` (the transaction's list), not yet in a group; each in its own color, or all in `color`."""
    from .objects import ExtractionResult
    doc = target_obj.Document
    out = []
    for i, m in enumerate(matches):
        obj = doc.addObject("App::FeaturePython", "Similar")
        created.append(obj)
        ExtractionResult(obj)
        obj.Target = target_obj
        obj.Reference = ref_obj
        obj.ReferenceText = ref_text
        obj.Transform = App.Matrix(*[float(x) for row in _field(m, "transform") for x in row])
        obj.Score = float(_field(m, "score"))
        obj.MaxError = float(_field(m, "max_error"))
        obj.RmsError = float(_field(m, "rms_error"))
        obj.Scale = float(_field(m, "scale"))
        obj.Center = App.Vector(*[float(x) for x in _field(m, "center")])
        obj.Faces = [int(f) for f in _field(m, "faces")]
        obj.Pairs = int(_field(m, "pairs"))
        obj.Mirrored = bool(_field(m, "mirrored"))
        obj.Color = color if color is not None else PALETTE[i % len(PALETTE)]
        if App.GuiUp:
            from .view_providers import ViewProviderResult
            ViewProviderResult(obj.ViewObject)
        out.append(obj)
    return out


def result_group(doc, created):
    """The document's "Similar features" group, made (and listed in `created`) if it is not there."""
    group = doc.getObject(RESULT_GROUP)
    if group is None:
        group = doc.addObject("App::DocumentObjectGroup", RESULT_GROUP)
        created.append(group)
        group.Label = "Similar features"
    return group


def add_results(target_obj, reference, result):
    """Records a computed result as FeatureExtractResult objects (replacing earlier results for the same
    target and reference), in one transaction; on any error the document is left as it was."""
    doc = target_obj.Document
    ref_obj, ref_text = _reference_link(reference)
    with _changes(doc, "Extract similar features") as created:
        group = result_group(doc, created)
        old = [o for o in results_for(target_obj) if getattr(o, "Reference", None) == ref_obj and getattr(o, "ReferenceText", ref_text) == ref_text]
        new = add_match_objects(target_obj, ref_obj, ref_text, result.matches, created)
        group.addObjects(new)
        for o in old:  # only once everything new exists
            doc.removeObject(o.Name)
        # labelled once the old results are gone: FreeCAD keeps labels unique, and a re-run labelled
        # beside its predecessors came out as "Similar 2 (0.99)001" (issue 11)
        for i, (obj, m) in enumerate(zip(new, result.matches)):
            obj.Label = f"Similar {i + 1} ({m.score:.2f})"
        doc.recompute()
    if App.GuiUp:
        from .view_providers import recolor
        recolor(target_obj)
    return new


# ---------------------------------------------------------------------------------------------
# FE meshes of a reference feature folder on every instance (issue 5)

def _fem_mesh(fe_mesh):
    """A FreeCAD FemMesh from the core's FeMesh. Node ids are kept; elements are numbered 1..n in the
    mesh's order (InpElementIds of the FEM object keeps the .inp ids)."""
    import Fem
    m = Fem.FemMesh()
    nodes = fe_mesh.nodes
    ids = list(fe_mesh.node_ids) or list(range(1, len(nodes) + 1))
    for nid, (x, y, z) in zip(ids, nodes):
        m.addNode(float(x), float(y), float(z), int(nid))
    original_ids = []
    n = 0
    for kind, eids, conn, _ in fe_mesh.blocks:
        for eid, row in zip(eids, conn):
            n += 1
            corners = [int(ids[k]) for k in row]
            if kind in ("S3", "S4"):
                m.addFace(corners, n)
            elif kind == "C3D4":  # SMESH turns a tetrahedron the other way round (FreeCAD's writer reorders 1 0 2 3: Abaqus's turn again)
                m.addVolume([corners[0], corners[2], corners[1], corners[3]], n)
            elif kind == "C3D10":  # likewise, and the edge middles follow their corners (FreeCAD writes it back)
                m.addVolume([corners[k] for k in (0, 2, 1, 3, 6, 5, 4, 7, 9, 8)], n)
            else:
                m.addVolume(corners, n)
            original_ids.append(int(eid))
    return m, original_ids


def place_meshes(target_obj, feature_dir, progress=None, **params):
    """Finds the instances of a reference feature folder's geometry on `target_obj` and places the
    feature's FE mesh on each: one result object per instance (as extract() makes) and one FEM mesh
    object (Fem::FemMeshObject) per instance, colored by element quality, in the result group.
    Returns the FEM mesh objects. On any error the document is left as it was."""
    import os
    try:
        feature = fx.read_feature(feature_dir)
    except ValueError as e:
        raise FeatureExtractError(str(e))
    result, tgt = _computed(prepare(target_obj, feature.geometry_path, **params), progress)
    transferred = [fx.transfer_mesh(feature.mesh, m.transform, tgt, spec_json=feature.spec_json) for m in result.matches]
    doc = target_obj.Document
    from .objects import FeatureMesh
    with _changes(doc, "Place FE meshes") as created:
        results = add_results(target_obj, feature.geometry_path, result)
        created.extend(results)
        group = doc.getObject(RESULT_GROUP)
        for old in [o for o in meshes_for(target_obj) if getattr(o, "FeatureFolder", "") == feature_dir]:
            doc.removeObject(old.Name)
        meshes = []
        for i, (r, t) in enumerate(zip(results, transferred)):
            obj = doc.addObject("Fem::FemMeshObjectPython", "FEMesh")
            created.append(obj)
            FeatureMesh(obj)
            obj.Label = f"FE mesh {i + 1} ({os.path.basename(os.path.normpath(feature_dir))})"
            femmesh, element_ids = _fem_mesh(t.mesh)
            obj.FemMesh = femmesh
            obj.InpElementIds = element_ids
            obj.Target = target_obj
            obj.Result = r
            obj.FeatureFolder = feature_dir
            obj.Specification = t.spec_json
            obj.ElementIds = list(range(1, len(element_ids) + 1))
            sj = t.quality_after["scaled_jacobian"]
            obj.ScaledJacobian = [float(x) for x in sj]
            summary = t.summary_after
            obj.MinScaledJacobian = float(summary["min_scaled_jacobian"])
            obj.InvertedElements = int(summary["inverted"])
            obj.UnprojectedNodes = int(t.unprojected)
            obj.NodeSets = sorted(t.mesh.node_sets)
            if App.GuiUp:
                from .view_providers import ViewProviderFeatureMesh
                ViewProviderFeatureMesh(obj.ViewObject)
            group.addObject(obj)
            meshes.append(obj)
        doc.recompute()
    return meshes


# ---------------------------------------------------------------------------------------------
# One mesh of the whole part, ready for CalculiX (issue 12)

def _cli():
    """The featureextract program: $FEATUREEXTRACT_CLI, else beside the Python module's build tree
    (build/python/featureextract -> build/featureextract), else on PATH."""
    import os
    import shutil
    env = os.environ.get("FEATUREEXTRACT_CLI")
    if env and os.path.isfile(env):
        return env
    here = os.path.dirname(os.path.abspath(fx.__file__))
    # build/python/featureextract -> build/featureextract; installed: P/lib/pythonX/dist-packages/featureextract -> P/bin
    for cand in (os.path.join(here, "..", "..", "featureextract"), os.path.join(here, "..", "..", "..", "..", "bin", "featureextract")):
        if os.path.isfile(cand):
            return os.path.normpath(cand)
    found = shutil.which("featureextract")
    if found:
        return found
    raise FeatureExtractError("the featureextract program is not found (set FEATUREEXTRACT_CLI)")


def run_cli(args, progress=None):
    """Runs `featureextract ARGS...` as a child process and returns what it printed on stdout.
    Its progress lines (`featureextract: STAGE NN%`) go to progress(stage, fraction); progress
    returning False kills it (featureextract.Cancelled). A failure raises FeatureExtractError with the
    program's last line, its one-line message."""
    import re
    import subprocess
    import threading
    proc = subprocess.Popen([_cli(), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = []
    reader = threading.Thread(target=lambda: out.append(proc.stdout.read()), daemon=True)
    reader.start()  # stdout drained beside stderr, so that neither pipe fills up and blocks the child
    last = ""
    for line in proc.stderr:
        line = line.rstrip("\n")
        m = re.match(r"featureextract: (.*) (\d+)%$", line)
        if m:
            if progress is not None and progress(m.group(1), int(m.group(2)) / 100.0) is False:
                proc.kill()
                proc.wait()
                raise fx.Cancelled("cancelled")
        elif line:
            last = line
    reader.join()
    if proc.wait() != 0:
        raise FeatureExtractError(last.replace("featureextract: ", "", 1) or f"featureextract {args[0]} failed (exit {proc.returncode})")
    return "".join(out)


def _bolt_faces(shape, nodes, face_numbers, tol):
    """The faces (FaceN) among face_numbers on which most of the given node positions lie."""
    import Part
    votes = {}
    for x, y, z in nodes:
        v = Part.Vertex(App.Vector(x, y, z))
        for n in face_numbers:
            if v.distToShape(shape.Faces[n - 1])[0] <= tol:
                votes[n] = votes.get(n, 0) + 1
    return sorted(n for n, c in votes.items() if c >= 0.2 * len(nodes))


_part_meshes = {}  # (shape, folders, options) -> output folder of a finished mesh-part run


def _part_mesh_key(target_obj, shape, feature_dirs, solid, size, force, seed, linear):
    return (target_obj.Document.Name, target_obj.Name, shape.hashCode(), tuple(feature_dirs),
            bool(solid), size, float(force), int(seed), bool(linear))


def compute_part_mesh(target_obj, feature_dirs, solid=True, size=None, force=100.0, progress=None, seed=1, shape=None,
                      linear=False):
    """Runs `featureextract mesh-part` on the part (a child process: no fault in meshing can take
    FreeCAD down) and returns its output folder; the document is not touched, so this may run in the
    background (pass shape=target_shape(target_obj), taken on the GUI thread). progress(stage,
    fraction) returning False cancels (fx.Cancelled)."""
    import os
    import tempfile
    if isinstance(feature_dirs, str):
        feature_dirs = [feature_dirs]
    if not feature_dirs:
        raise FeatureExtractError("no feature folder given")
    shape = shape if shape is not None else target_shape(target_obj)
    key = _part_mesh_key(target_obj, shape, feature_dirs, solid, size, force, seed, linear)
    if key in _part_meshes and os.path.isfile(os.path.join(_part_meshes[key], "mesh_part.json")):
        return _part_meshes[key]
    work = tempfile.mkdtemp(prefix="fe_mesh_part_")
    brep = os.path.join(work, "part.brep")
    shape.exportBrep(brep)
    out = os.path.join(work, "out")
    cmd = ["mesh-part", "--target", brep, "--output", out, "--seed", str(int(seed))]
    for d in feature_dirs:
        cmd += ["--feature", d]
    if solid:
        cmd.append("--solid")
        if linear:
            cmd.append("--linear")
    if size:
        cmd += ["--size", repr(float(size))]
    cmd += ["--force", repr(float(force))]
    run_cli(cmd, progress)
    _part_meshes[key] = out
    return out


def mesh_part(target_obj, feature_dirs, solid=True, size=None, force=100.0, progress=None, seed=1, linear=False):
    """One FE mesh of the whole part (`featureextract mesh-part`, see compute_part_mesh): every instance
    of every feature folder carries the feature's mesh, gmsh meshes the rest, conforming; with
    solid=True the surface is filled with 10-node tetrahedra (C3D10; linear=True: 4-node, C3D4). Adds a Fem::FemMeshObject of it and a CalculiX
    analysis ready to solve in the FEM workbench: steel, the part held on the face mesh-part chose
    (the largest one away from the features), a force of `force` N on the faces of each feature's
    rigid bolt set, a CalculiX solver. Returns (mesh object, analysis). On any error the document is
    left as it was."""
    import json
    import os
    if isinstance(feature_dirs, str):
        feature_dirs = [feature_dirs]
    shape = target_shape(target_obj)
    out = compute_part_mesh(target_obj, feature_dirs, solid, size, force, progress, seed, shape, linear)
    with open(os.path.join(out, "mesh_part.json")) as f:
        report = json.load(f)
    mesh_file = os.path.join(out, "part_solid.inp" if solid else "part.inp")
    fem = fx.read_fe_mesh(mesh_file)
    surface = fx.read_fe_mesh(os.path.join(out, "part.inp")) if solid else fem
    doc = target_obj.Document
    import ObjectsFem
    with _changes(doc, "Mesh part with feature rules") as created:
        obj = doc.addObject("Fem::FemMeshObject", "PartMesh")
        created.append(obj)
        obj.Label = f"Part mesh ({len(report['instances'])} feature instances)"
        femmesh, _ = _fem_mesh(fem)
        obj.FemMesh = femmesh
        analysis = ObjectsFem.makeAnalysis(doc, "FeatureAnalysis")
        created.append(analysis)
        analysis.addObject(obj)
        solver = ObjectsFem.makeSolverCalculixCcxTools(doc, "CalculiX")
        created.append(solver)
        solver.AnalysisType = "static"
        analysis.addObject(solver)
        material = ObjectsFem.makeMaterialSolid(doc, "Steel")
        created.append(material)
        mat = material.Material
        mat.update({"Name": "Steel", "YoungsModulus": "210000 MPa", "PoissonRatio": "0.3", "Density": "7850 kg/m^3"})
        material.Material = mat
        analysis.addObject(material)
        if not solid:
            thick = ObjectsFem.makeElementGeometry2D(doc, 0.2, "Thickness")
            created.append(thick)
            analysis.addObject(thick)
        fixed = ObjectsFem.makeConstraintFixed(doc, "Support")
        created.append(fixed)
        fixed.References = [(target_obj, f"Face{report['analysis']['fixed_face']}")]
        analysis.addObject(fixed)
        forces = []
        for inst in report["instances"]:
            for rs in inst.get("rigid_sets", []):
                rows = surface.node_sets.get(rs, [])
                pts = [tuple(surface.nodes[i]) for i in rows]
                faces = _bolt_faces(shape, pts, inst["faces"], 1e-3 * max(1.0, shape.BoundBox.DiagonalLength))
                if not faces:
                    continue
                c = ObjectsFem.makeConstraintForce(doc, f"Bolt_{inst['name']}")
                created.append(c)
                c.References = [(target_obj, f"Face{n}") for n in faces]
                c.Force = float(force)
                analysis.addObject(c)
                forces.append(c)
        doc.recompute()
    return obj, analysis
