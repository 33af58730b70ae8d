#!/usr/bin/python3
"""The benchmark suite (issue 4): every case of build/models/suite (made by `fe_make_models --suite`),
our engine and the peers on the same inputs, scored against the generator's ground truth; the
scaling runs (`--scaling`); the tables and the plot go into docs/benchmarks.md.

    bench/run_suite.sh                      # installs the peers' packages, builds, generates, runs, writes the doc
    /usr/bin/python3 bench/suite.py --help  # options (which methods, cases, repeats)

How an instance is scored, the same way for every method: the reference surface (area-weighted
samples of its STL) is mapped by the method's 4x4 transform. A target face (FaceN) counts as found
when at least half of its area lies within 2 % of the mapped feature's diagonal from the mapped
samples; a found instance is a true positive when the intersection-over-union of its face set with a
ground-truth instance's is at least 0.5 (one-to-one, best first). For mesh targets (no faces) the same
is done with triangle areas inside the truth box. Fit error: RMS distance from the mapped reference
samples to the target surface, divided by the diagonal of the mapped samples.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def log(msg):
    print(f"suite: {msg}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------
# running a method: wall time and peak memory of that child alone (wait4's rusage)

def run_child(cmd, timeout):
    """Runs cmd under GNU time, which reports the peak resident memory of that command alone (a
    child forked from this Python process would count this process's memory too)."""
    import tempfile
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        t0 = time.monotonic()
        try:
            p = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", tf.name, *cmd], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"ok": False, "error": f"timed out after {timeout} s", "seconds": timeout, "peak_mb": None}
        seconds = time.monotonic() - t0
        lines = [l for l in open(tf.name).read().splitlines() if l.strip().isdigit()]
    peak = int(lines[-1]) / 1024 if lines else None
    out = {"ok": p.returncode == 0, "seconds": seconds, "peak_mb": peak}
    if p.returncode != 0:
        err = p.stderr.decode("utf-8", "replace").strip().splitlines()
        err = [l for l in err if not l.startswith("Command exited")]
        out["error"] = f"exit {p.returncode}: {err[-1] if err else ''}"
    return out


def methods(build, selected):
    o3d = os.path.join(ROOT, "bench", "peers", "open3d_peer.py")
    table = {
        "ours": lambda ref, tgt, out, seed: [os.path.join(build, "featureextract"), "extract", "-q", "-r", ref["step"],
                                             "-t", tgt["step"], "-o", out, "--seed", str(seed)],
        "ours-cylindrical": lambda ref, tgt, out, seed: [os.path.join(build, "featureextract"), "extract", "-q", "-r",
                                                         ref["step"], "-t", tgt["step"], "-o", out, "--seed", str(seed),
                                                         "--set", "ridge_rut_spacing=0.05"],
        "pcl-gc": lambda ref, tgt, out, seed: [os.path.join(build, "fe_pcl_peer"), "--reference", ref["stl"],
                                               "--target", tgt["stl"], "--output", out, "--seed", str(seed)],
        "open3d": lambda ref, tgt, out, seed: ["/usr/bin/python3", o3d, "--reference", ref["stl"], "--target", tgt["stl"],
                                               "--output", out, "--seed", str(seed)],
        "open3d-scaling": lambda ref, tgt, out, seed: ["/usr/bin/python3", o3d, "--reference", ref["stl"], "--target",
                                                       tgt["stl"], "--output", out, "--seed", str(seed), "--scaling"],
    }
    return {k: v for k, v in table.items() if k in selected}


# ---------------------------------------------------------------------------------------------
# geometry for scoring

def load_mesh(path):
    import featureextract as fx
    m = fx.read_shape(path)
    return np.asarray(m.vertices), np.asarray(m.triangles), np.asarray(m.face_ids)


def tri_areas_centroids(v, t):
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1), (a + b + c) / 3.0


def sample_surface(v, t, n, seed=0):
    area, _ = tri_areas_centroids(v, t)
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(t), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    a, b, c = v[t[idx, 0]], v[t[idx, 1]], v[t[idx, 2]]
    return (1 - s)[:, None] * a + (s * (1 - r2))[:, None] * b + (s * r2)[:, None] * c


def apply(H, p):
    q = np.c_[p, np.ones(len(p))] @ np.asarray(H, float).T
    with np.errstate(divide="ignore", invalid="ignore"):
        return q[:, :3] / q[:, 3:4]


class Target:
    def __init__(self, path):
        import open3d as o3d
        self.v, self.t, self.faces = load_mesh(path)
        self.area, self.centroid = tri_areas_centroids(self.v, self.t)
        mesh = o3d.t.geometry.TriangleMesh()
        mesh.vertex.positions = o3d.core.Tensor(self.v.astype(np.float32))
        mesh.triangle.indices = o3d.core.Tensor(self.t.astype(np.int32))
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(mesh)
        self.face_area = np.bincount(self.faces, weights=self.area) if self.faces.max() > 0 else None

    def distance(self, pts):
        import open3d as o3d
        return self.scene.compute_distance(o3d.core.Tensor(pts.astype(np.float32))).numpy()

    def region(self, mapped, tol):
        """Triangles (bool) within tol of the mapped samples, and the faces mostly covered."""
        from scipy.spatial import cKDTree
        d, _ = cKDTree(mapped).query(self.centroid, distance_upper_bound=tol)
        near = np.isfinite(d)
        faces = set()
        if self.face_area is not None:
            cov = np.bincount(self.faces[near], weights=self.area[near], minlength=len(self.face_area))
            faces = {int(f) for f in np.nonzero(cov >= 0.5 * np.maximum(self.face_area, 1e-300))[0] if f > 0}
        return near, faces


def iou(a, b):
    return len(a & b) / len(a | b) if a | b else 0.0


def score_case(case, target, ref_samples, result):
    """TP/FP/FN, IoU of the matched instances, fit errors."""
    truth = case["instances"]
    mesh_case = case.get("target_is_mesh", False)
    truth_sets = []
    for inst in truth:
        if mesh_case:
            lo, hi = np.array(inst["box"][0]) - 1.0, np.array(inst["box"][1]) + 1.0
            inside = np.all((target.centroid >= lo) & (target.centroid <= hi), axis=1) & (target.centroid[:, 2] > 0.05)
            truth_sets.append(inside)
        else:
            truth_sets.append(set(inst["faces"]))
    preds = []
    for m in result.get("matches", []):
        H = np.asarray(m["transform"], float)
        mapped = apply(H, ref_samples)
        if not np.all(np.isfinite(mapped)):
            preds.append({"region": None, "fit": math.inf})
            continue
        diag = float(np.linalg.norm(mapped.max(0) - mapped.min(0)))
        near, faces = target.region(mapped, 0.02 * diag)
        d = target.distance(mapped)
        preds.append({"region": near if mesh_case else faces, "fit": float(np.sqrt(np.mean(d ** 2)) / diag)})
    # greedy one-to-one matching by IoU
    pairs = []
    for i, p in enumerate(preds):
        if p["region"] is None:
            continue
        for j, tset in enumerate(truth_sets):
            if mesh_case:
                inter = target.area[p["region"] & tset].sum()
                union = target.area[p["region"] | tset].sum()
                v = inter / union if union > 0 else 0.0
            else:
                v = iou(p["region"], tset)
            pairs.append((v, i, j))
    pairs.sort(reverse=True)
    used_p, used_t, matched = set(), set(), []
    for v, i, j in pairs:
        if v < 0.5 or i in used_p or j in used_t:
            continue
        used_p.add(i)
        used_t.add(j)
        matched.append((i, j, v))
    tp = len(matched)
    ms = result.get("matches", [])
    before_after = [(ms[i]["rms_error_unrefined"], ms[i]["rms_error"], ms[i].get("scale", 1.0)) for i, _, _ in matched
                    if "rms_error_unrefined" in ms[i] and ms[i]["rms_error_unrefined"] is not None]
    return {"before_after": before_after, "tp": tp, "fp": len(preds) - tp, "fn": len(truth) - tp, "truth": len(truth), "found": len(preds),
            "iou": [v for _, _, v in matched], "fit": [preds[i]["fit"] for i, _, _ in matched],
            "missed": [truth[j]["label"] for j in range(len(truth)) if j not in used_t]}


# ---------------------------------------------------------------------------------------------

def median(xs):
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return statistics.median(xs) if xs else None


def fmt(x, nd=2, pct=False):
    if x is None:
        return "-"
    return f"{100 * x:.{nd}f} %" if pct else f"{x:.{nd}f}"


def run_suite(args):
    suite_dir = os.path.join(args.models, "suite")
    spec = json.load(open(os.path.join(suite_dir, "suite.json")))
    cases = [c for c in spec["cases"] if not args.cases or c["name"] in args.cases]
    ms = methods(args.build, args.methods)
    out_dir = os.path.join(args.build, "suite_results")
    os.makedirs(out_dir, exist_ok=True)
    rows = {}
    kept = {}
    if args.keep:  # rows of methods not run again, from the previous run's summary
        prev = json.load(open(os.path.join(out_dir, "summary.json")))["rows"]
        kept = {tuple(k.split("|")): v for k, v in prev.items() if k.split("|")[1] in args.keep}
    ref_cache = {}
    for case in cases:
        ref = {"step": os.path.join(suite_dir, case["reference"] + ".step"), "stl": os.path.join(suite_dir, case["reference"] + ".stl")}
        if case.get("target_is_mesh"):
            tgt = {"step": os.path.join(suite_dir, case["target"] + ".stl"), "stl": os.path.join(suite_dir, case["target"] + ".stl")}
        else:
            tgt = {"step": os.path.join(suite_dir, case["target"] + ".step"), "stl": os.path.join(suite_dir, case["target"] + ".stl")}
        if ref["stl"] not in ref_cache:
            v, t, _ = load_mesh(ref["stl"])
            ref_cache[ref["stl"]] = sample_surface(v, t, 20000)
            ref_cache[ref["stl"] + "#diag"] = float(np.linalg.norm(v.max(0) - v.min(0)))
        target = Target(tgt["step"])
        for name, cmd in ms.items():
            if (case["name"], name) in kept:
                rows[(case["name"], name)] = kept[(case["name"], name)]
                continue
            out = os.path.join(out_dir, f"{case['name']}.{name}.json")
            if os.path.exists(out):
                os.remove(out)
            run = run_child(cmd(ref, tgt, out, args.seed), args.timeout)
            if run["ok"]:
                result = json.load(open(out))
                s = score_case(case, target, ref_cache[ref["stl"]], result)
                s["timings"] = result.get("timings", {})
                L = ref_cache[ref["stl"] + "#diag"]
                s["before_after"] = [(b / (L * sc), a / (L * sc)) for b, a, sc in s["before_after"]]
            else:
                s = {"tp": 0, "fp": 0, "fn": len(case["instances"]), "truth": len(case["instances"]), "found": 0,
                     "iou": [], "fit": [], "missed": ["(run failed)"], "error": run.get("error")}
            s.update(seconds=run["seconds"], peak_mb=run["peak_mb"])
            rows[(case["name"], name)] = s
            log(f"{case['name']:18s} {name:15s} {s['tp']}/{s['truth']} found, {s['fp']} false, "
                f"{run['seconds']:.1f} s, {run['peak_mb'] or 0:.0f} MB{'  ' + s['error'] if 'error' in s else ''}")
    return cases, list(ms), rows


def run_scaling(args):
    sdir = os.path.join(args.models, "scaling")
    spec = json.load(open(os.path.join(sdir, "scaling.json")))
    ref = os.path.join(args.models, "suite", "rib_reference.step")
    out = []
    for size in spec["sizes"]:
        runs = []
        for rep in range(args.repeats):
            o = os.path.join(args.build, "suite_results", f"scaling_{size['file']}.json")
            r = run_child([os.path.join(args.build, "featureextract"), "extract", "-q", "-r", ref, "-t",
                           os.path.join(sdir, size["file"]), "-o", o, "--seed", "1"], args.timeout)
            if r["ok"]:
                j = json.load(open(o))
                r["instances"] = len(j["matches"])
                r["stages"] = j["timings"]
            runs.append(r)
            log(f"scaling {size['file']}: {r['seconds']:.1f} s, {r['peak_mb'] or 0:.0f} MB, "
                f"{r.get('instances', '?')} of {spec['ribs']} ribs{'' if r['ok'] else '  ' + r.get('error', '')}")
        ok = [r for r in runs if r["ok"]]
        out.append({"file": size["file"], "triangles": size["triangles"], "runs": len(runs),
                    "seconds": median([r["seconds"] for r in ok]), "peak_mb": median([r["peak_mb"] for r in ok]),
                    "instances": ok[0]["instances"] if ok else None, "ribs": spec["ribs"],
                    "stages": ok[len(ok) // 2]["stages"] if ok else {}})
    return out


TRANSFERS = [("rib", "five_ribs"), ("rib", "six_features"), ("rib", "iso_scale"), ("boss", "bosses")]


def run_transfers(args):
    """`featureextract mesh` with the shipped feature folders: node placement and element quality."""
    out = []
    for feature, case in TRANSFERS:
        odir = os.path.join(args.build, "suite_results", f"mesh_{feature}_{case}")
        run = run_child([os.path.join(args.build, "featureextract"), "mesh", "-q", "--feature",
                         os.path.join(ROOT, "Resources", "library", feature), "--target",
                         os.path.join(args.models, "suite", case + ".step"), "--output", odir, "--seed", str(args.seed)],
                        args.timeout)
        row = {"feature": feature, "case": case, "seconds": run["seconds"], "error": run.get("error")}
        if run["ok"]:
            j = json.load(open(os.path.join(odir, "result.json")))
            ts = [m["transfer"] for m in j["matches"] if "nodes" in m.get("transfer", {})]
            row.update(instances=len(j["matches"]), nodes=j["feature"]["nodes"], elements=j["feature"]["elements"],
                       unprojected=sum(t["unprojected_nodes"] for t in ts),
                       max_surface=max((t["max_surface_distance"] for t in ts), default=None),
                       max_move=max((t["max_projection_distance"] for t in ts), default=None),
                       inverted=sum(t["quality_after"]["inverted"] for t in ts),
                       sj_before=ts[0]["quality_before"]["min_scaled_jacobian"] if ts else None,
                       sj_after=min((t["quality_after"]["min_scaled_jacobian"] for t in ts), default=None),
                       ar_before=ts[0]["quality_before"]["median_aspect_ratio"] if ts else None,
                       ar_after=median([t["quality_after"]["median_aspect_ratio"] for t in ts]),
                       angle_before=ts[0]["quality_before"]["min_angle_deg"] if ts else None,
                       angle_after=min((t["quality_after"]["min_angle_deg"] for t in ts), default=None))
        log(f"mesh {feature} on {case}: {row.get('instances', 0)} instances, {row.get('inverted', '?')} inverted elements")
        out.append(row)
    return out


def plot_scaling(scaling, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    pts = [s for s in scaling if s["seconds"] is not None]
    n = [s["triangles"] for s in pts]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].loglog(n, [s["seconds"] for s in pts], "o-", label="FeatureExtract")
    ax[0].axhline(30, color="r", ls="--", lw=1, label="goal: 1M triangles in 30 s")
    ax[0].set_xlabel("target triangles")
    ax[0].set_ylabel("end to end, s (median)")
    ax[1].loglog(n, [s["peak_mb"] for s in pts], "o-", color="C1", label="FeatureExtract")
    ax[1].axhline(4096, color="r", ls="--", lw=1, label="goal: 4 GB")
    ax[1].set_xlabel("target triangles")
    ax[1].set_ylabel("peak resident memory, MB")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.suptitle("Scaling with target size (2-core machine, rib reference, plate of 12 ribs and 3 bosses)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


# ---------------------------------------------------------------------------------------------
# the document

def summary(rows, method, cases):
    tp = sum(rows[(c["name"], method)]["tp"] for c in cases if (c["name"], method) in rows)
    fp = sum(rows[(c["name"], method)]["fp"] for c in cases if (c["name"], method) in rows)
    fn = sum(rows[(c["name"], method)]["fn"] for c in cases if (c["name"], method) in rows)
    fits = [f for c in cases if (c["name"], method) in rows for f in rows[(c["name"], method)]["fit"]]
    ious = [f for c in cases if (c["name"], method) in rows for f in rows[(c["name"], method)]["iou"]]
    secs = [rows[(c["name"], method)]["seconds"] for c in cases if (c["name"], method) in rows]
    return {"recall": tp / (tp + fn) if tp + fn else None, "precision": tp / (tp + fp) if tp + fp else None,
            "tp": tp, "fp": fp, "fn": fn, "fit": median(fits), "iou": median(ious), "seconds": sum(secs)}


def markdown(cases, names, rows, scaling, args, transfers=None):
    L = []
    L.append(f"Generated by `bench/run_suite.sh` on {time.strftime('%Y-%m-%d')} (seed {args.seed}; 2-core shared machine). "
             "Cases and ground truth come from `fe_make_models --suite`; scoring as described in `bench/suite.py`: "
             "an instance counts when the faces it covers overlap a true instance's faces with IoU >= 0.5; "
             "fit error = RMS distance of the mapped reference to the target surface / feature diagonal.\n")
    L.append("### Over the suite\n")
    L.append("| method | recall | precision | found / true / false | median face IoU | median fit error | total time s |")
    L.append("|---|---|---|---|---|---|---|")
    for n in names:
        s = summary(rows, n, cases)
        L.append(f"| {n} | {fmt(s['recall'])} | {fmt(s['precision'])} | {s['tp']} / {s['tp'] + s['fn']} / {s['fp']} | "
                 f"{fmt(s['iou'])} | {fmt(s['fit'], 2, True)} | {s['seconds']:.1f} |")
    L.append("")
    L.append("### Per case\n")
    L.append("Cell: found of true (+ false), median fit error; time and peak memory of the whole run.\n")
    L.append("| case | what | " + " | ".join(names) + " |")
    L.append("|---|---|" + "---|" * len(names))
    for c in cases:
        cells = []
        for n in names:
            r = rows.get((c["name"], n))
            if r is None:
                cells.append("-")
                continue
            cell = f"{r['tp']}/{r['truth']}" + (f" (+{r['fp']})" if r["fp"] else "")
            if r["fit"]:
                cell += f", {fmt(median(r['fit']), 1, True)}"
            cell += f"; {r['seconds']:.1f} s, {fmt(r['peak_mb'], 0)} MB"
            if "error" in r:
                cell += f"; **{r['error']}**"
            cells.append(cell)
        L.append(f"| {c['name']} | {c['what']} | " + " | ".join(cells) + " |")
    L.append("")
    misses = [(c["name"], n, rows[(c["name"], n)]["missed"]) for c in cases for n in names[:1]
              if (c["name"], n) in rows and rows[(c["name"], n)]["missed"]]
    if misses:
        L.append(f"Missed by {names[0]}: " + "; ".join(f"{c}: {', '.join(m)}" for c, _, m in misses) + ".\n")
    if "ours" in names:
        stages = {}
        for c in cases:
            for k, v in rows.get((c["name"], "ours"), {}).get("timings", {}).items():
                if k != "total" and v is not None:
                    stages[k] = stages.get(k, 0.0) + v
        if stages:
            total = sum(stages.values())
            L.append("### Time per stage (ours, summed over the suite)\n")
            L.append("| stage | s | share |")
            L.append("|---|---|---|")
            for k, v in stages.items():
                L.append(f"| {k} | {v:.2f} | {100 * v / total:.0f} % |")
            L.append(f"| all stages (reading and tessellation not included) | {total:.2f} | |")
            L.append("")
        ba = [x for c in cases if (c["name"], "ours") in rows for x in rows[(c["name"], "ours")].get("before_after", [])]
        if ba:
            before = [b for b, _ in ba]
            after = [a for _, a in ba]
            worse = sum(1 for b, a in ba if a > b * (1 + 1e-9))
            L.append("### Fit before and after the surface refinement (ours)\n")
            L.append("The engine's own RMS distance of the mapped reference to the target surface, over the true instances found, "
                     "divided by the reference diagonal times the instance's scale.\n")
            L.append("| instances | median before | median after | worst after | instances worse after |")
            L.append("|---|---|---|---|---|")
            L.append(f"| {len(ba)} | {fmt(median(before), 2, True)} | {fmt(median(after), 2, True)} | "
                     f"{fmt(max(after), 2, True)} | {worse} |")
            L.append("")
    if transfers:
        L.append("### FE mesh transfer (`featureextract mesh`)\n")
        L.append("The shipped feature folders (`Resources/library`) placed on every instance found. Distances in mm; "
                 "SJ = scaled Jacobian (1 perfect, < 0 inverted), AR = aspect ratio, angle = smallest element angle.\n")
        L.append("| feature | target | instances | nodes each | unprojected nodes | max node-surface distance | "
                 "largest node move | inverted elements | min SJ before / after | median AR before / after | "
                 "min angle before / after |")
        L.append("|---|---|---|---|---|---|---|---|---|---|---|")
        for t in transfers:
            if t.get("error"):
                L.append(f"| {t['feature']} | {t['case']} | **{t['error']}** |" + " |" * 8)
                continue
            L.append(f"| {t['feature']} | {t['case']} | {t['instances']} | {t['nodes']} | {t['unprojected']} | "
                     f"{t['max_surface']:.1e} | {fmt(t['max_move'])} | {t['inverted']} | {fmt(t['sj_before'])} / "
                     f"{fmt(t['sj_after'])} | {fmt(t['ar_before'])} / {fmt(t['ar_after'])} | "
                     f"{fmt(t['angle_before'], 0)} / {fmt(t['angle_after'], 0)} |")
        L.append("")
    if scaling:
        L.append("### Scaling with target size\n")
        L.append("![time and memory against target size](images/scaling.png)\n")
        L.append(f"Median of {scaling[0]['runs']} runs each; reference `rib_reference.step`, default parameters.\n")
        L.append("| target | triangles | end to end s | peak MB | ribs found | SHOT s | RANSAC s |")
        L.append("|---|---|---|---|---|---|---|")
        for s in scaling:
            st = s["stages"]
            L.append(f"| {s['file']} | {s['triangles']:,} | {fmt(s['seconds'], 1)} | {fmt(s['peak_mb'], 0)} | "
                     f"{s['instances']} of {s['ribs']} | {fmt(st.get('target_shot'), 1)} | {fmt(st.get('ransac'), 1)} |")
        L.append("")
    return "\n".join(L)


def write_doc(path, text):
    begin, end = "<!-- suite:begin (written by bench/suite.py) -->", "<!-- suite:end -->"
    doc = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    block = f"{begin}\n{text}\n{end}"
    if begin in doc and end in doc:
        doc = doc[:doc.index(begin)] + block + doc[doc.index(end) + len(end):]
    else:
        doc = doc.rstrip() + "\n\n## The benchmark suite\n\n" + block + "\n"
    with open(path + ".tmp", "w") as f:
        f.write(doc)
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"), help="build folder (default build/)")
    ap.add_argument("--models", default=None, help="models folder (default BUILD/models)")
    ap.add_argument("--methods", nargs="+", default=["ours", "ours-cylindrical", "pcl-gc", "open3d", "open3d-scaling"],
                    help="ours = defaults; ours-cylindrical = the task panel's Cylindrical preset (ridge_rut_spacing 0.05)")
    ap.add_argument("--cases", nargs="*", help="only these cases (default all)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", nargs="*", default=[], help="methods whose rows are taken from the previous run "
                    "(build/suite_results/summary.json) instead of running them again")
    ap.add_argument("--repeats", type=int, default=3, help="runs per scaling size (median quoted)")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--keep-scaling", action="store_true", help="take the scaling rows from the previous run")
    ap.add_argument("--timeout", type=float, default=600, help="seconds per run")
    ap.add_argument("--doc", default=os.path.join(ROOT, "docs", "benchmarks.md"), help="document to update ('' = none)")
    args = ap.parse_args()
    args.models = args.models or os.path.join(args.build, "models")
    sys.path.insert(0, os.path.join(args.build, "python"))
    cases, names, rows = run_suite(args)
    transfers = run_transfers(args) if "ours" in names else None
    if args.keep_scaling:
        scaling = json.load(open(os.path.join(args.build, "suite_results", "summary.json")))["scaling"]
    else:
        scaling = None if args.no_scaling else run_scaling(args)
    if scaling and not args.keep_scaling:
        plot_scaling(scaling, os.path.join(ROOT, "docs", "images", "scaling.png"))
    text = markdown(cases, names, rows, scaling, args, transfers)
    json.dump({"rows": {f"{k[0]}|{k[1]}": v for k, v in rows.items()}, "scaling": scaling},
              open(os.path.join(args.build, "suite_results", "summary.json"), "w"), indent=1, default=str)
    print(text)
    if args.doc:
        write_doc(args.doc, text)
        log(f"wrote {args.doc}")


if __name__ == "__main__":
    main()
