#!/usr/bin/python3
"""FeatureExtract's feature library, library search, batch over a vault and its report (issue 13).

The `featureextract` CLI runs this program for its `library`, `search`, `batch` and `report`
subcommands (it is found next to the CLI, or through $FE_LIBRARY_PROGRAM):

    featureextract library add LIB --from PART --faces 12,13,14 --name "mounting lug" [--class lug]
    featureextract library list LIB [--json]
    featureextract library check LIB
    featureextract search --library LIB --target PART --output OUT.json
    featureextract batch --library LIB --parts 'vault/**/*.step' --db results.sqlite [--scheduler tcp://HOST:8786]
    featureextract report --db results.sqlite --output report.html [--csv matches.csv]

A library is a folder of feature folders (geometry, FE mesh, feature.json with the meshing rules and
how the feature is searched). `search` finds every instance of every feature on one part, says
where two features claim the same faces, and ranks the claims. `batch` runs one `search` per part
on Dask (a LocalCluster sized to the machine, or the user's own scheduler) and writes the results
into SQLite or PostgreSQL (schema in db.py's SCHEMA, versioned). Exit codes as the CLI's: 0 done,
2 usage, 3 invalid input, 4 internal error, 5 time limit.
"""
import argparse
import glob
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import fe_db  # noqa: E402

EXIT_USAGE, EXIT_INPUT, EXIT_INTERNAL, EXIT_TIME = 2, 3, 4, 5
PROG = "featureextract"


class UserError(Exception):
    """Bad input or usage: one line for the user, exit code."""

    def __init__(self, message, code=EXIT_INPUT):
        super().__init__(" ".join(str(message).split()))  # one line, whatever a file name holds
        self.code = code


def fx():
    """The compiled module (build/python beside this program, or installed)."""
    try:
        import featureextract
    except ImportError:
        # beside this program in the build tree; installed (P/share/featureextract): P's Python folders
        import glob
        for d in (os.environ.get("FEATUREEXTRACT_PYTHONPATH", ""), os.path.join(HERE, "python"),
                  *sorted(glob.glob(os.path.join(HERE, "..", "..", "lib", "python3*", "*-packages")))):
            if d and os.path.isdir(d) and d not in sys.path:
                sys.path.insert(0, d)
        try:
            import featureextract
        except ImportError as e:
            raise UserError(f"the featureextract Python module is not found ({e}); build it (./setup.sh)", EXIT_INTERNAL)
    return featureextract


def cli_path():
    for p in (os.environ.get("FE_CLI", ""), os.path.join(HERE, "featureextract"), os.path.join(HERE, "..", "..", "bin", "featureextract")):
        if p and os.access(p, os.X_OK):
            return p
    raise UserError("the featureextract CLI is not next to fe_library.py (set FE_CLI)", EXIT_INTERNAL)


# ---------------------------------------------------------------------------------------------
# the library

def file_hash(path, h=None):
    h = h or hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h


def feature_hash(folder, spec):
    """Content hash of a feature: its feature.json and the files it names (geometry, meshes)."""
    h = hashlib.sha256()
    h.update(json.dumps(spec, sort_keys=True).encode())
    for key in ("geometry", "mesh", "mesh_msh"):
        if spec.get(key):
            p = os.path.join(folder, spec[key])
            if os.path.isfile(p):
                file_hash(p, h)
    return h.hexdigest()


def load_feature(folder):
    path = os.path.join(folder, "feature.json")
    try:
        with open(path, encoding="utf-8") as f:
            spec = json.load(f)
    except FileNotFoundError:
        raise UserError(f"{path}: no feature.json (not a feature folder)")
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise UserError(f"{path}: not readable JSON ({e})")
    if not isinstance(spec, dict) or not isinstance(spec.get("name"), str) or not spec["name"].strip():
        raise UserError(f"{path}: needs a \"name\" (text)")
    if not isinstance(spec.get("geometry"), str):
        raise UserError(f"{path}: needs a \"geometry\" file name")
    search = spec.get("search", {})
    if not isinstance(search, dict):
        raise UserError(f"{path}: \"search\" must be an object")
    return {"name": spec["name"], "class": spec.get("class", ""), "dir": os.path.abspath(folder), "spec": spec,
            "hash": feature_hash(folder, spec), "geometry": os.path.join(folder, spec["geometry"]), "search": search}


def load_library(lib):
    if not os.path.isdir(lib):
        raise UserError(f"{lib}: not a folder (a library is a folder of feature folders)")
    folders = sorted(d for d in (os.path.join(lib, x) for x in os.listdir(lib)) if os.path.isfile(os.path.join(d, "feature.json")))
    if not folders:
        raise UserError(f"{lib}: no feature folders in it (each needs a feature.json)")
    feats = [load_feature(d) for d in folders]
    names = [f["name"] for f in feats]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise UserError(f"{lib}: two features are named {dup[0]!r}")
    return feats


def library_hash(feats):
    return hashlib.sha256("".join(f["hash"] for f in feats).encode()).hexdigest()


LIBRARY_SIZE_LADDER = 3


def available_cores():
    """The cores this process may run on (its affinity mask: a batch job's or container's share)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def size_class(fxm, diagonal, ladder=LIBRARY_SIZE_LADDER):
    """The doubling a feature's size falls in, after the engine's rounding to the size ladder (features
    on one rung fall in the same class, so they share one tessellation and its descriptions)."""
    import math
    return math.floor(math.log2(fxm.size_on_ladder(max(diagonal, 1e-9), ladder)) + 1e-9)


def search_params(fxm, feature, overrides):
    """A feature's search parameters: the engine's defaults, the feature's own (feature.json
    "search": scale_min, scale_max, params), then the caller's. The library search rounds feature
    sizes to a ladder of 3 per doubling (size_ladder, the SHOT radius step), so that features of
    nearby sizes share the part's descriptions; a feature or the caller may set it (0 = exact)."""
    values = {"size_ladder": LIBRARY_SIZE_LADDER}
    s = feature["search"]
    for k in ("scale_min", "scale_max"):
        if k in s:
            values[k] = s[k]
    values.update(s.get("params", {}))
    values.update(overrides)
    try:
        return fxm.make_params(**values)
    except (ValueError, TypeError) as e:
        raise UserError(f"{feature['dir']}/feature.json: search parameters: {e}")


def render_thumbnail(mesh, path, colors=None, size_px=256):
    """A shaded picture of a tessellated shape (matplotlib, no display); colors: RGB per triangle."""
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    v = np.asarray(mesh.vertices, dtype=float)
    t = np.asarray(mesh.triangles, dtype=int)
    tri = v[t]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    light = np.array([0.4, -0.5, 0.77])
    shade = 0.35 + 0.65 * np.abs(n @ (light / np.linalg.norm(light)))
    base = np.tile([0.62, 0.66, 0.72], (len(t), 1)) if colors is None else np.asarray(colors, dtype=float)
    fc = np.clip(base * shade[:, None], 0, 1)
    fig = plt.figure(figsize=(size_px / 64, size_px / 64), dpi=64)
    ax = fig.add_axes([0, 0, 1, 1], projection="3d")
    ax.add_collection3d(Poly3DCollection(tri, facecolors=fc, edgecolors=fc, linewidths=0.3))  # edges: no seams
    lo, hi = v.min(axis=0), v.max(axis=0)
    ext = np.maximum(hi - lo, 1e-3 * max((hi - lo).max(), 1e-9))  # a flat part keeps some thickness
    ax.set_xlim(lo[0], lo[0] + ext[0])
    ax.set_ylim(lo[1], lo[1] + ext[1])
    ax.set_zlim(lo[2], lo[2] + ext[2])
    ax.set_box_aspect(ext, zoom=1.05)  # true proportions, the part filling the picture (a plate is not a speck)
    ax.view_init(elev=30, azim=-60)
    ax.set_axis_off()
    fig.savefig(path, dpi=64)
    plt.close(fig)


def library_add(a):
    fxm = fx()
    faces = []
    for x in a.faces.split(","):
        x = x.strip()
        if x:
            if not x.isdigit() or int(x) < 1:
                raise UserError(f"--faces: {x!r} is not a face number (FreeCAD's FaceN: 1, 2, ...)", EXIT_USAGE)
            faces.append(int(x))
    if not faces:
        raise UserError("--faces: give the picked faces, e.g. --faces 12,13,14", EXIT_USAGE)
    if not os.path.isfile(a.source):
        raise UserError(f"{a.source}: no such file")
    part = fxm.read_shape(a.source)
    bad = [f for f in faces if f > part.num_faces]
    if bad:
        raise UserError(f"{a.source}: has {part.num_faces} faces; --faces asks for {bad[0]}")
    size = a.size
    if size is None:  # a twentieth of the picked faces' extent, two significant digits
        import numpy as np
        ids = np.asarray(part.face_ids)
        tri = np.asarray(part.triangles)[np.isin(ids, faces)]
        pts = np.asarray(part.vertices)[tri.reshape(-1)]
        d = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) / 20
        size = float(f"{d:.2g}") if d > 0 else 1.0
    os.makedirs(a.library, exist_ok=True)
    folder = os.path.join(a.library, a.folder or slug(a.name))
    if os.path.exists(os.path.join(folder, "feature.json")) and not a.replace:
        raise UserError(f"{folder}: a feature is already there (--replace to overwrite it)")
    maker = os.path.join(HERE, "make_feature.py")
    cmd = [sys.executable, maker, a.source, folder, "--faces", ",".join(map(str, faces)), "--name", a.name, "--size", repr(size)]
    if a.rigid_faces:
        cmd += ["--rigid-faces", a.rigid_faces]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise UserError(f"{a.source}: the feature mesh failed: {(r.stderr or r.stdout).strip().splitlines()[-1:]}")
    spec_path = os.path.join(folder, "feature.json")
    with open(spec_path, encoding="utf-8") as f:
        spec = json.load(f)
    spec["class"] = a.cls or slug(a.name).lower()
    if a.description:
        spec["description"] = a.description
    spec["search"] = {"scale_min": a.scale_min, "scale_max": a.scale_max, "params": {}}
    geo = fxm.read_shape(os.path.join(folder, spec["geometry"]))
    render_thumbnail(geo, os.path.join(folder, "thumbnail.png"))
    spec["thumbnail"] = "thumbnail.png"
    with open(spec_path, "w", newline="\n") as f:
        json.dump(spec, f, indent=2)
        f.write("\n")
    print(f"{PROG} library add: {a.name} ({len(faces)} faces of {os.path.basename(a.source)}, element size {size:g}) -> {folder}")
    return 0


def slug(text):
    out = "".join(c.lower() if c.isalnum() else "_" for c in text)
    while "__" in out:
        out = out.replace("__", "_")
    return out.strip("_") or "feature"


def rule_text(spec):
    return "; ".join(r.get("text", r.get("rule", "")) for r in spec.get("rules", []) if isinstance(r, dict))


def library_list(a):
    feats = load_library(a.library)
    if a.json:
        def thumbnail(f):
            t = f["spec"].get("thumbnail")
            return os.path.join(f["dir"], t) if isinstance(t, str) and os.path.isfile(os.path.join(f["dir"], t)) else None
        print(json.dumps([{"name": f["name"], "class": f["class"], "dir": f["dir"], "hash": f["hash"], "rules": rule_text(f["spec"]),
                           "description": f["spec"].get("description", "") if isinstance(f["spec"].get("description"), str) else "",
                           "thumbnail": thumbnail(f), "search": f["search"]} for f in feats], indent=2))
        return 0
    w = max(len(f["name"]) for f in feats)
    for f in feats:
        s = f["search"]
        rng = f"{s.get('scale_min', 'default')}-{s.get('scale_max', 'default')}x" if s else "default scales"
        print(f"{f['name']:<{w}}  {f['class'] or '-':<12} {rng:<14} {rule_text(f['spec'])}")
    print(f"{len(feats)} features in {a.library}")
    return 0


def library_check(a):
    """Every feature folder readable by the engine (geometry, FE mesh, rules), its thumbnail there.
    One line per problem; exit 3 when there is any."""
    fxm = fx()
    if not os.path.isdir(a.library):
        raise UserError(f"{a.library}: not a folder")
    problems, ok = [], 0
    for d in sorted(os.path.join(a.library, x) for x in os.listdir(a.library)):
        if not os.path.isdir(d):
            continue
        try:
            f = load_feature(d)
            fxm.read_feature(d)  # geometry, mesh, specification: as the engine reads them
            geo = fxm.read_shape(f["geometry"])
            if geo.triangles.shape[0] == 0:
                raise UserError(f"{f['geometry']}: no surface")
            if not os.path.isfile(os.path.join(d, f["spec"].get("thumbnail", "thumbnail.png"))):
                raise UserError(f"{d}: no thumbnail.png (make it with: {PROG} library thumbnail {a.library})")
            ok += 1
        except UserError as e:
            problems.append(str(e))
        except ValueError as e:  # fx.InputError
            problems.append(" ".join(str(e).split()))
    for p in problems:
        print(f"{PROG} library check: {p}", file=sys.stderr)
    print(f"{PROG} library check: {ok} features ok, {len(problems)} with problems in {a.library}")
    return EXIT_INPUT if problems or ok == 0 else 0


def library_thumbnail(a):
    fxm = fx()
    for f in load_library(a.library):
        render_thumbnail(fxm.read_shape(f["geometry"]), os.path.join(f["dir"], f["spec"].get("thumbnail", "thumbnail.png")))
        print(f"{PROG} library thumbnail: {f['name']}")
    return 0


# ---------------------------------------------------------------------------------------------
# search one part with the whole library

def search_part(library, target, overrides=None, time_limit=None, progress=None):
    """Every instance of every feature of `library` on `target`: the result as a dict (the JSON of
    `featureextract search`). A feature that cannot be searched (its reference has no key points, say)
    gets an "error" and the others go on; an unreadable target raises UserError."""
    fxm = fx()
    overrides = dict(overrides or {})
    feats = load_library(library)
    if not os.path.isfile(target):
        raise UserError(f"{target}: no such file")
    refs = []
    for f in feats:
        try:
            refs.append(fxm.read_shape(f["geometry"]))
        except ValueError as e:
            raise UserError(str(e))
    t0 = time.monotonic()
    # The target is tessellated once per size class of features (sizes within a factor of 2 share one
    # tessellation, as fine as the class's smallest feature needs), not for the library's smallest
    # feature: a 10 mm slot must not make a 1 m housing's mesh a hundred times finer for every feature.
    # Each tessellation keeps its descriptions for reuse (PreparedTarget).
    import math
    current = {"key": None, "target": None}
    made = {"tessellations": 0, "descriptions": 0}

    # each feature's parameters (the library's size ladder, or the feature's or caller's own): features
    # on one rung share a size class, so one tessellation and its descriptions
    params = [search_params(fxm, f, overrides) for f in feats]

    def prepared_for(i):
        ref, ladder = refs[i], int(params[i].size_ladder)
        k = size_class(fxm, ref.diagonal, ladder)
        if current["key"] != k:  # a new size class: the last one's descriptions are let go (memory)
            if current["target"] is not None:
                made["descriptions"] += current["target"].descriptions_built
            rel, _ = fxm.tessellation_for_feature(ref.diagonal)
            # as fine as the class's smallest feature needs (a rung rounds sizes up to 2^(1/(2 ladder)))
            smallest = 2.0 ** k / (2.0 ** (0.5 / ladder) if ladder > 0 else 1.0)
            try:
                mesh = fxm.read_shape(target, relative_deflection=rel, absolute_deflection=rel * smallest)
            except ValueError as e:
                raise UserError(str(e))
            current["key"], current["target"] = k, fxm.PreparedTarget(mesh)
            made["tessellations"] += 1
        return current["target"]
    order = sorted(range(len(feats)), key=lambda i: -refs[i].diagonal)  # the coarsest tessellation first
    first = prepared_for(order[0]).mesh
    out = {"target": {"path": os.path.abspath(target), "faces": int(first.num_faces), "triangles": int(first.triangles.shape[0])},
           "library": {"path": os.path.abspath(library), "hash": library_hash(feats), "features": len(feats)},
           "features": [], "overlaps": []}
    entries = [None] * len(feats)
    position = {i: n for n, i in enumerate(order)}

    def search_one(i, threads=None):
        f, ref, n = feats[i], refs[i], position[i]
        if progress:
            progress(n, len(feats), f["name"])
        entry = {"name": f["name"], "class": f["class"], "dir": f["dir"], "hash": f["hash"], "rules": rule_text(f["spec"]),
                 "matches": [], "error": None, "warnings": []}
        t1 = time.monotonic()
        try:
            p = search_params(fxm, f, overrides)  # its own copy: searches may run side by side
            if threads is not None:
                p.threads = threads
            if time_limit:
                left = time_limit - (time.monotonic() - t0)
                if left <= 0:
                    raise fxm.TimeLimitError(f"{target}: time limit of {time_limit:g} s reached before {f['name']}")
                p.time_limit = left
            res = json.loads(prepared_for(i).extract(ref, p, (lambda stage, fr, n=n, name=f["name"]: progress(n, len(feats), name, stage, fr))
                                                       if progress else None).to_json())
            entry["matches"] = res.get("matches", [])
            entry["params"] = res.get("parameters")  # as used: the feature's, the ladder's and the caller's
            entry["warnings"] = res.get("warnings", [])  # e.g. a box's cut faces left out, the ridge-and-rut fallback
            entry["ransac_searches"] = res.get("pairs", {}).get("ransac_searches", 0)  # what a feature that is not there cost
        except fxm.TimeLimitError:
            raise
        except ValueError as e:  # InputError: this feature cannot be searched; the others go on
            entry["error"] = " ".join(str(e).split())
        entry["seconds"] = round(time.monotonic() - t1, 3)
        entries[i] = entry

    # Features side by side. One feature's search keeps about 1.4 of 2 cores busy (RANSAC scores
    # its hypotheses a few at a time), so the features that share a target description (a rung of
    # the size ladder, the same search settings) are searched `jobs` at a time, each on its share of
    # the cores, once the rung's first feature, searched alone on all of them, has described the part
    # (describing uses many cores well). Rung by rung, so that the description is still in the
    # prepared target's small cache. Each result is the same for any thread count, so the same as
    # searched one after another.
    budget = int(overrides.get("threads", 0)) or available_cores()
    rungs = {}
    for i in order:
        ladder = int(params[i].size_ladder)
        key = (fxm.size_on_ladder(max(refs[i].diagonal, 1e-9), ladder), json.dumps(feats[i]["search"], sort_keys=True))
        rungs.setdefault(key, []).append(i)
    for first, *rest in rungs.values():
        search_one(first)
        jobs = min(budget, len(rest))
        if jobs <= 1:
            for i in rest:
                search_one(i)
            continue
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            for fut in [pool.submit(search_one, i, max(1, budget // jobs)) for i in rest]:
                fut.result()  # a time limit reached ends the search (the others stop at the same limit)
    out["features"] = entries  # in the library's order
    out["overlaps"] = overlaps(out["features"])
    out["tessellations"] = made["tessellations"]
    out["descriptions_built"] = made["descriptions"] + current["target"].descriptions_built
    out["seconds"] = round(time.monotonic() - t0, 3)
    return out


def overlaps(features):
    """Target faces claimed by instances of two or more features: one entry per group of claims
    that share faces, the claims ranked by score (the first is the one a mesh keeps)."""
    claims = []
    for f in features:
        for i, m in enumerate(f["matches"]):
            faces = set(m.get("faces") or [])
            if faces:
                claims.append({"feature": f["name"], "match": i, "score": m.get("score", 0.0), "faces": faces})
    groups, seen = [], set()
    for a in range(len(claims)):
        if a in seen:
            continue
        group, frontier = {a}, [a]  # the claims linked to claim a through shared faces
        while frontier:
            x = frontier.pop()
            for b in range(len(claims)):
                if b not in group and claims[b]["feature"] != claims[x]["feature"] and claims[b]["faces"] & claims[x]["faces"]:
                    group.add(b)
                    frontier.append(b)
        seen |= group
        if len({claims[g]["feature"] for g in group}) > 1:
            ranked = sorted(group, key=lambda g: (-claims[g]["score"], claims[g]["feature"], claims[g]["match"]))
            shared = set.union(*(claims[g]["faces"] for g in group))
            groups.append({"faces": sorted(shared),
                           "claims": [{"feature": claims[g]["feature"], "match": claims[g]["match"], "score": claims[g]["score"],
                                       "rank": r + 1} for r, g in enumerate(ranked)]})
    return groups


def search_cmd(a):
    overrides = parse_sets(a.set)
    if a.seed is not None:
        overrides["seed"] = a.seed

    shown = {"line": None}

    def progress(k, n, name, stage=None, fraction=0.0):
        """One line per feature, and the engine's stage progress as `extract` prints it
        (`featureextract: NAME (K of N): STAGE NN%`, what the workbench's progress bar reads)."""
        if a.quiet:
            return True
        if stage is None:
            print(f"{PROG} search: feature {k + 1} of {n}: {name}", file=sys.stderr, flush=True)
            return True
        line = f"{PROG}: {name} ({k + 1} of {n}): {stage} {int(100 * min(max(fraction, 0.0), 1.0))}%"
        if line != shown["line"]:
            shown["line"] = line
            print(line, file=sys.stderr, flush=True)
        return True
    fxm = fx()
    try:
        res = search_part(a.library, a.target, overrides, a.time_limit, progress)
    except fxm.TimeLimitError as e:
        raise UserError(str(e), EXIT_TIME)
    with open(a.output, "w", newline="\n") as f:
        json.dump(res, f, indent=1)
        f.write("\n")
    found = sum(len(f["matches"]) for f in res["features"])
    errs = [f for f in res["features"] if f["error"]]
    if not a.quiet:
        for f in res["features"]:
            print(f"{PROG} search: {f['name']}: {len(f['matches'])} found" + (f" (not searched: {f['error']})" if f["error"] else ""),
                  file=sys.stderr)
            for w in f["warnings"]:
                print(f"{PROG} search: {f['name']}: warning: {w}", file=sys.stderr)
        print(f"{PROG} search: {found} instances of {len(res['features'])} features on {os.path.basename(a.target)}, "
              f"{len(res['overlaps'])} overlaps, {res['seconds']:.1f} s -> {a.output}", file=sys.stderr)
    return 0 if len(errs) < len(res["features"]) else EXIT_INPUT


def parse_sets(items):
    out = {}
    for s in items or []:
        if "=" not in s:
            raise UserError(f"--set {s!r}: expected NAME=VALUE", EXIT_USAGE)
        k, v = s.split("=", 1)
        try:
            out[k] = json.loads(v)
        except json.JSONDecodeError:
            out[k] = v
    return out


# ---------------------------------------------------------------------------------------------
# batch over a vault on Dask, into a database

def run_part(path, library, overrides, timeout, threads=0):
    """One Dask task: `featureextract search` on one part, in its own process (a part that crashes a
    reader or hangs costs that process, not the worker). Returns a plain dict."""
    with tempfile.TemporaryDirectory(prefix="fe_batch_") as tmp:
        out = os.path.join(tmp, "out.json")
        cmd = [sys.executable, os.path.abspath(__file__), "search", "--library", library, "--target", path, "--output", out, "--quiet"]
        for k, v in sorted(overrides.items()):
            cmd += ["--set", f"{k}={json.dumps(v)}"]
        if threads > 0:  # the same result for any thread count: not a parameter of the result
            cmd += ["--set", f"threads={threads}"]
        if timeout:
            cmd += ["--time-limit", repr(timeout)]
        t0 = time.monotonic()
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=(timeout * 1.5 + 60) if timeout else None)
        except subprocess.TimeoutExpired:
            return {"path": path, "ok": False, "error": f"{path}: no answer within {timeout * 1.5 + 60:g} s", "seconds": time.monotonic() - t0}
        if r.returncode in (0, EXIT_INPUT) and os.path.isfile(out):  # read and searched (exit 3: no feature could be)
            with open(out) as f:
                res = json.load(f)
            return {"path": path, "ok": True, "result": res, "seconds": time.monotonic() - t0}
        lines = [x for x in (r.stderr or "").strip().splitlines() if x.strip()]
        msg = lines[-1] if lines else f"exit {r.returncode}"
        if r.returncode < 0:
            msg = f"{path}: the search process died (signal {-r.returncode})"
        return {"path": path, "ok": False, "error": " ".join(msg.split()), "seconds": time.monotonic() - t0}


def expand_parts(patterns):
    parts = []
    for pat in patterns:
        hits = sorted(glob.glob(pat, recursive=True))
        if not hits and os.path.isfile(pat):
            hits = [pat]
        if not hits:
            raise UserError(f"--parts {pat!r}: no file matches", EXIT_INPUT)
        parts += [os.path.abspath(h) for h in hits if os.path.isfile(h)]
    seen, out = set(), []
    for p in parts:
        if p not in seen:
            seen.add(p)
            out.append(p)
    return out


def batch_cmd(a):
    feats = load_library(a.library)
    parts = expand_parts(a.parts)
    overrides = parse_sets(a.set)
    overrides["seed"] = a.seed
    if "threads" in overrides:
        a.threads = int(overrides.pop("threads"))
    if a.threads < 0:
        raise UserError(f"--threads {a.threads}: must be 0 (automatic) or more", EXIT_USAGE)
    db = fe_db.connect(a.db)
    lib_hash = library_hash(feats)
    params_json = json.dumps(overrides, sort_keys=True)
    params_hash = hashlib.sha256((params_json + "|" + str(a.time_limit)).encode()).hexdigest()
    version = program_version()
    # incremental: a part whose content, library and parameters are in the database already is skipped
    to_search, skipped = [], 0
    hashes = {}
    for p in parts:
        hashes[p] = file_hash(p).hexdigest()
        if db.has_result(p, hashes[p], lib_hash, params_hash):
            skipped += 1
        else:
            to_search.append(p)
    run_id = db.start_run(params_json, params_hash, lib_hash, version, len(parts))
    for f in feats:
        db.feature_id(f["name"], f["hash"], f["class"])
    say = (lambda *x: None) if a.quiet else (lambda s: print(f"{PROG} batch: {s}", file=sys.stderr, flush=True))
    say(f"{len(parts)} parts, {skipped} already in {a.db}, {len(to_search)} to search with {len(feats)} features")
    t0 = time.monotonic()
    done = errors = found = 0
    def record(r):
        nonlocal done, errors, found
        p = r["path"]
        found += db.store(run_id, p, hashes[p], lib_hash, params_hash, r)
        done += 1
        errors += 0 if r["ok"] else 1
        el = time.monotonic() - t0
        rate = done / el * 60 if el > 0 else 0.0
        eta = (len(to_search) - done) / (done / el) if done and el > 0 else 0.0
        say(f"{done}/{len(to_search)} parts, {rate:.1f} parts/min, ETA {eta:.0f} s, {errors} errors, {found} instances"
            + ("" if r["ok"] else f" | {r['error']}"))

    if to_search and a.serial:  # one part after the other in this process's children: the reference for Dask's rows
        for p in to_search:
            record(run_part(p, os.path.abspath(a.library), overrides, a.time_limit, a.threads))
    elif to_search:
        from dask.distributed import Client, LocalCluster, as_completed
        cluster = None
        if a.scheduler:
            client = Client(a.scheduler, timeout="20s")
        else:
            n = a.workers or max(1, os.cpu_count() or 1)
            if not a.threads:  # the cores shared out among the local workers (a search uses all it is given)
                a.threads = max(1, (os.cpu_count() or 1) // n)
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=40)
            client = Client(cluster)
        try:
            futures = [client.submit(run_part, p, os.path.abspath(a.library), overrides, a.time_limit, a.threads, key=f"part-{hashes[p][:16]}-{k}",
                                     retries=2, pure=False) for k, p in enumerate(to_search)]
            for fut in as_completed(futures):
                try:
                    r = fut.result()
                except Exception as e:  # a worker died on it three times (KilledWorker) or the task raised
                    r = {"path": to_search[futures.index(fut)], "ok": False, "error": " ".join(f"{type(e).__name__}: {e}".split()), "seconds": 0.0}
                record(r)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    db.finish_run(run_id, done, errors)
    el = time.monotonic() - t0
    say(f"done: {done} searched ({errors} errors), {skipped} skipped, {found} instances, {el:.1f} s -> {a.db}")
    db.close()
    return 0


def program_version():
    try:
        r = subprocess.run([cli_path(), "--version"], capture_output=True, text=True, timeout=20)
        return r.stdout.strip() or "unknown"
    except (UserError, OSError, subprocess.SubprocessError):
        return "unknown"


# ---------------------------------------------------------------------------------------------
# report

FEATURE_COLORS = [(0.89, 0.10, 0.11), (0.22, 0.49, 0.72), (0.30, 0.69, 0.29), (1.00, 0.50, 0.00), (0.60, 0.31, 0.64),
                  (0.65, 0.34, 0.16), (0.97, 0.51, 0.75), (0.00, 0.75, 0.75), (0.74, 0.74, 0.13), (0.10, 0.10, 0.55)]


def _hex(rgb):
    return "#" + "".join(f"{int(round(255 * c)):02x}" for c in rgb)


def part_pictures(rows, matches, feats, folder, limit):
    """For each of the first `limit` parts: a picture with every instance's faces in its feature's
    color (the part read again, coarsely) and the part's matches as JSON, in `folder`. Returns
    {path: (picture file or None, JSON file)}; a part that cannot be read again gets no picture."""
    os.makedirs(folder, exist_ok=True)
    by_part = {}
    for m in matches:
        by_part.setdefault(m["path"], []).append(m)
    out = {}
    fxm = None
    for n, r in enumerate(rows):
        mine = by_part.get(r["path"], [])
        js = f"part{n + 1}.json"
        with open(os.path.join(folder, js), "w", encoding="utf-8", newline="\n") as f:
            json.dump({"path": r["path"], "matches": [{k: (json.loads(v) if k in ("faces", "transform") and isinstance(v, str) else v)
                                                       for k, v in m.items() if k not in ("path", "result_id")} for m in mine]}, f, indent=1)
        pic = None
        if n < limit and r["ok"] and os.path.isfile(r["path"]):
            try:
                fxm = fxm or fx()
                import numpy as np
                mesh = fxm.read_shape(r["path"])
                face_color = {}
                for m in sorted(mine, key=lambda m: m["score"]):  # the best scored shows where two claim a face
                    for face in (json.loads(m["faces"]) if isinstance(m["faces"], str) else m["faces"]) or []:
                        face_color[int(face)] = FEATURE_COLORS[feats.index(m["feature"]) % len(FEATURE_COLORS)]
                ids = np.asarray(mesh.face_ids)
                colors = np.tile([0.62, 0.66, 0.72], (len(ids), 1))
                for face, c in face_color.items():
                    colors[ids == face] = c
                pic = f"part{n + 1}.png"
                render_thumbnail(mesh, os.path.join(folder, pic), colors)
            except Exception as e:  # noqa: BLE001  (a part changed or gone since the batch: no picture)
                print(f"{PROG} report: {r['path']}: no picture ({' '.join(str(e).split())})", file=sys.stderr)
                pic = None
        out[r["path"]] = (pic, js)
    return out


def report_cmd(a):
    import html
    db = fe_db.connect(a.db, create=False)
    rows = db.summary()
    matches = db.matches()
    db.close()
    feats = sorted({m["feature"] for m in matches} | {f for r in rows for f in r["counts"]})
    latest = {r["result_id"] for r in rows}
    matches = [m for m in matches if m["result_id"] in latest]  # a part searched again: its newest result
    files = os.path.splitext(a.output)[0] + "_files"
    pictures = part_pictures(rows, matches, feats, files, a.thumbnails)
    if a.csv:
        import csv
        with open(a.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["part", "feature", "score", "rms_error", "scale", "mirrored", "faces", "transform"])
            for m in matches:
                w.writerow([m["path"], m["feature"], m["score"], m["rms_error"], m["scale"], m["mirrored"], m["faces"], m["transform"]])
    out = ["<!doctype html><html><head><meta charset='utf-8'><title>FeatureExtract report</title>",
           "<style>body{font-family:sans-serif}table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:3px 8px}"
           "td.n{text-align:right}.err{color:#a00}</style></head><body>",
           f"<h1>FeatureExtract: {len(rows)} parts</h1>",
           f"<p>{sum(1 for r in rows if r['error'])} parts with errors; {len(matches)} instances.</p>",
           "<p>" + " ".join(f"<span style='background:{_hex(FEATURE_COLORS[k % len(FEATURE_COLORS)])};padding:0 6px'>&nbsp;</span> "
                            f"{html.escape(f)}" for k, f in enumerate(feats)) + "</p>",
           "<table><tr><th>part</th><th>picture</th>" + "".join(f"<th>{html.escape(f)}</th>" for f in feats)
           + "<th>seconds</th><th>error, or features not searched</th></tr>"]
    rel = os.path.basename(files)
    for r in rows:
        cells = "".join(f"<td class='n'>{r['counts'].get(f, 0)}</td>" for f in feats)
        err = (f"<td class='err'>{html.escape(r['error'])}</td>" if r["error"]
               else f"<td>{'<br>'.join(html.escape(x) for x in r['notes'].splitlines())}</td>")
        pic, js = pictures.get(r["path"], (None, None))
        img = f"<img src='{html.escape(rel + '/' + pic)}' width='128' height='128' alt='instances colored'>" if pic else ""
        link = f" <a href='{html.escape(rel + '/' + js)}'>matches</a>" if js else ""
        out.append(f"<tr><td>{html.escape(r['path'])}{link}</td><td>{img}</td>{cells}<td class='n'>{r['seconds']:.1f}</td>{err}</tr>")
    out.append("</table>")
    if len(rows) > a.thumbnails:
        out.append(f"<p>Pictures of the first {a.thumbnails} parts only (--thumbnails).</p>")
    out.append("<h2>Totals per feature</h2><table><tr><th>feature</th><th>instances</th><th>parts</th></tr>")
    for f in feats:
        out.append(f"<tr><td>{html.escape(f)}</td><td class='n'>{sum(r['counts'].get(f, 0) for r in rows)}</td>"
                   f"<td class='n'>{sum(1 for r in rows if r['counts'].get(f, 0))}</td></tr>")
    out.append("</table></body></html>")
    with open(a.output, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(out) + "\n")
    print(f"{PROG} report: {len(rows)} parts, {len(matches)} instances -> {a.output}" + (f", {a.csv}" if a.csv else ""))
    return 0


# ---------------------------------------------------------------------------------------------

def parser():
    ap = argparse.ArgumentParser(prog=PROG, description="feature library, library search, batch over a vault, report")
    sub = ap.add_subparsers(dest="cmd", required=True)
    lib = sub.add_parser("library", help="a folder of reference features").add_subparsers(dest="lcmd", required=True)
    ad = lib.add_parser("add", help="add the faces picked on a part as a feature")
    ad.add_argument("library")
    ad.add_argument("--from", dest="source", required=True, help="the part (STEP, BREP)")
    ad.add_argument("--faces", required=True, help="FreeCAD FaceN numbers, comma separated")
    ad.add_argument("--name", required=True)
    ad.add_argument("--class", dest="cls", default="")
    ad.add_argument("--description", default="")
    ad.add_argument("--size", type=float, default=None, help="element size (default: a twentieth of the faces' extent)")
    ad.add_argument("--rigid-faces", default="", help="faces whose nodes form a rigid bolt connection")
    ad.add_argument("--scale-min", type=float, default=0.8)
    ad.add_argument("--scale-max", type=float, default=2.6)
    ad.add_argument("--folder", default="", help="folder name in the library (default: from the name)")
    ad.add_argument("--replace", action="store_true")
    ls = lib.add_parser("list", help="the features, their classes and rules")
    ls.add_argument("library")
    ls.add_argument("--json", action="store_true")
    ck = lib.add_parser("check", help="every feature folder readable, meshes valid")
    ck.add_argument("library")
    th = lib.add_parser("thumbnail", help="(re)draw every feature's thumbnail.png")
    th.add_argument("library")
    se = sub.add_parser("search", help="every instance of every library feature on one part")
    se.add_argument("--library", required=True)
    se.add_argument("--target", required=True)
    se.add_argument("--output", required=True)
    se.add_argument("--seed", type=int, default=None)
    se.add_argument("--time-limit", type=float, default=None)
    se.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    se.add_argument("--quiet", "-q", action="store_true")
    ba = sub.add_parser("batch", help="search every part of a vault (Dask) into a database")
    ba.add_argument("--library", required=True)
    ba.add_argument("--parts", required=True, action="append", help="file pattern ('vault/**/*.step'); may repeat")
    ba.add_argument("--db", required=True, help="SQLite file, or postgresql://...")
    ba.add_argument("--scheduler", default="", help="tcp://HOST:8786 of a running `dask scheduler`")
    ba.add_argument("--workers", type=int, default=0, help="local worker processes (default: one per core)")
    ba.add_argument("--serial", action="store_true", help="no Dask: one part after the other (for comparison)")
    ba.add_argument("--threads", type=int, default=0,
                    help="threads per search (default: the cores shared out among local workers; all cores on a --scheduler cluster)")
    ba.add_argument("--seed", type=int, default=1)
    ba.add_argument("--time-limit", type=float, default=600.0, help="per part, seconds")
    ba.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ba.add_argument("--quiet", "-q", action="store_true")
    rp = sub.add_parser("report", help="an HTML page (and CSV) of a batch database")
    rp.add_argument("--db", required=True)
    rp.add_argument("--output", required=True)
    rp.add_argument("--csv", default="")
    rp.add_argument("--thumbnails", type=int, default=200, metavar="N",
                    help="pictures of the first N parts with their instances colored (0: none)")
    return ap


def main(argv=None):
    ap = parser()
    try:
        a = ap.parse_args(argv)
    except SystemExit as e:
        return EXIT_USAGE if e.code else 0
    try:
        if a.cmd == "library":
            return {"add": library_add, "list": library_list, "check": library_check, "thumbnail": library_thumbnail}[a.lcmd](a)
        return {"search": search_cmd, "batch": batch_cmd, "report": report_cmd}[a.cmd](a)
    except UserError as e:
        print(f"{PROG} {a.cmd}: {e}", file=sys.stderr)
        return e.code
    except fe_db.DbError as e:
        print(f"{PROG} {a.cmd}: {' '.join(str(e).split())}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print(f"{PROG} {a.cmd}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
