#!/usr/bin/python3
"""Whole-part FE meshes with feature rules, solved by CalculiX, beside a plain gmsh mesh (issue 12).

    /usr/bin/python3 bench/mesh_part.py --build build [--case NAME] [--out rows.json]

Per case: `featureextract mesh-part` (every instance carries its feature's mesh, gmsh meshes the rest,
conforming, filled with 10-node tetrahedra: --solid; 4-node ones with --linear) and `featureextract mesh-part --plain --solid` (gmsh meshes
everything; the same support and bolt faces), each solved by `ccx` (linear static: the face chosen as support held, a force on each bolt's
rigid body). Prints nodes, elements, quality, conformity, meshing and solver time, and the results
side by side: displacement of the bolt load points, the largest displacement, the largest von Mises
stress away from the features (nodes farther than two element sizes of the rest from every instance).
"""

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cases(build):
    feats = os.path.join(ROOT, "Resources", "library")
    return {
        "example_plate": {"target": os.path.join(build, "models", "ribs_bosses.step"),
                          "features": [os.path.join(feats, "rib"), os.path.join(feats, "boss")]},
        "boss_only": {"target": os.path.join(build, "models", "boss_only.step"),
                      "features": [os.path.join(feats, "boss")]},
        # NIST CTC-02's six mounting lugs; the feature is made from one lug's faces (top, the bolt hole's
        # two halves, the outer arc) by tools/make_feature.py, the hole being the bolt's rigid body
        "ctc02_lugs": {"target": CTC02, "make_feature": ["--faces", "197,198,199,229", "--rigid-faces", "198,199",
                                                         "--name", "mounting lug", "--size", "3"],
                       "extra": ["--size", "10"]},
    }


CTC02 = os.path.join(os.path.dirname(ROOT), "shared", "data", "real", "nist_ctc_02_asme1_rc.stp")


def run(cmd, cwd=None, timeout=1800):
    t = time.time()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    return p, time.time() - t


def read_dat_displacements(path):
    """node -> (ux, uy, uz) from ccx's .dat (*NODE PRINT U)."""
    out = {}
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) == 4 and re.fullmatch(r"\d+", v[0]):
                try:
                    out[int(v[0])] = tuple(float(x) for x in v[1:])
                except ValueError:
                    pass
    return out


def read_frd_stress(path):
    """node -> von Mises stress from ccx's ASCII .frd (the STRESS block)."""
    out, inside = {}, False
    with open(path) as f:
        for line in f:
            if line.startswith(" -4"):
                inside = line.split()[1] == "STRESS"
                continue
            if inside and line.startswith(" -3"):
                inside = False
                continue
            if inside and line.startswith(" -1"):
                node = int(line[3:13])
                s = [float(line[13 + 12 * k:25 + 12 * k]) for k in range(6)]
                sx, sy, sz, txy, tyz, tzx = s
                out[node] = math.sqrt(0.5 * ((sx - sy) ** 2 + (sy - sz) ** 2 + (sz - sx) ** 2)
                                      + 3 * (txy ** 2 + tyz ** 2 + tzx ** 2))
    return out


def read_inp_nodes(path):
    nodes, mode = {}, None
    with open(path) as f:
        for line in f:
            if line.startswith("*"):
                mode = "n" if line.upper().startswith("*NODE") else None
                continue
            if mode == "n":
                v = line.replace(",", " ").split()
                if len(v) >= 4:
                    nodes[int(v[0])] = tuple(float(x) for x in v[1:4])
    return nodes


def ref_nodes(deck):
    """reference node id -> rigid set name, from analysis.inp."""
    out = {}
    for m in re.finditer(r"\*RIGID BODY, NSET=(\S+), REF NODE=(\d+)", open(deck).read()):
        out[int(m.group(2))] = m.group(1)
    return out


def mesh_and_solve(exe, target, features, out_dir, plain, extra=()):
    cmd = [exe, "mesh-part", "--target", target, "--output", out_dir, "--quiet"] + list(extra)
    for f in features:
        cmd += ["--feature", f]
    if plain:
        cmd.append("--plain")
    p, mesh_s = run(cmd)
    if p.returncode != 0:
        raise RuntimeError(f"mesh-part failed ({p.returncode}): {p.stderr.strip()}")
    rep = json.load(open(os.path.join(out_dir, "mesh_part.json")))
    p, ccx_s = run(["ccx", "-i", "analysis"], cwd=out_dir)
    log = p.stdout + p.stderr
    rep["ccx"] = {"exit": p.returncode, "seconds": round(ccx_s, 2),
                  "errors": len(re.findall(r"\*ERROR", log)), "warnings": len(re.findall(r"\*WARNING", log)),
                  "first_message": next((l.strip() for l in log.splitlines() if "*ERROR" in l or "*WARNING" in l), "")}
    rep["mesh_seconds"] = round(mesh_s, 2)
    if p.returncode == 0 and rep["ccx"]["errors"] == 0:
        u = read_dat_displacements(os.path.join(out_dir, "analysis.dat"))
        vm = read_frd_stress(os.path.join(out_dir, "analysis.frd"))
        rep["u"], rep["vm"] = u, vm
        rep["refs"] = ref_nodes(os.path.join(out_dir, "analysis.inp"))
        rep["nodes_xyz"] = read_inp_nodes(os.path.join(out_dir, rep["analysis"]["mesh"]))
    return rep


def away_from(xyz, boxes, margin):
    for lo, hi in boxes:
        if all(lo[k] - margin <= xyz[k] <= hi[k] + margin for k in range(3)):
            return False
    return True


def compare(whole, plain):
    """The two analyses side by side."""
    size = whole["size"]
    boxes = []
    for inst in whole["instances"]:
        boxes.append((inst["bbox_min"], inst["bbox_max"]))
    rows = {}
    for name, r in (("whole", whole), ("plain", plain)):
        u = r["u"]
        umag = {n: math.sqrt(sum(c * c for c in v)) for n, v in u.items()}
        load = {r["refs"][n]: umag[n] for n in r["refs"] if n in umag}
        far = [r["vm"][n] for n, x in r["nodes_xyz"].items() if n in r["vm"] and away_from(x, boxes, 2 * size)]
        rows[name] = {"max_displacement": max(umag.values()), "load_point_displacement": load,
                      "max_von_mises_away": max(far) if far else float("nan"), "nodes_away": len(far)}
    w, p = rows["whole"], rows["plain"]
    rel = lambda a, b: abs(a - b) / max(abs(b), 1e-300)
    rows["relative_difference"] = {
        "max_displacement": rel(w["max_displacement"], p["max_displacement"]),
        "load_point_displacement": max((rel(w["load_point_displacement"][k], p["load_point_displacement"][k])
                                        for k in w["load_point_displacement"] if k in p["load_point_displacement"]),
                                       default=float("nan")),
        "max_von_mises_away": rel(w["max_von_mises_away"], p["max_von_mises_away"]),
    }
    return rows


def summary(r):
    q, c = r["quality"]["all"], r["conformity"]
    lines = [f"{r['case']}: {r['instances']} instances; surface {r['surface_nodes']} nodes / {r['surface_elements']} "
             f"elements (free edges {c['free_edges']}, duplicate nodes {c['duplicate_nodes']}, border nodes not joined "
             f"{c['border_nodes_not_joined']}, inverted {q['inverted']}, min scaled Jacobian {q['min_scaled_jacobian']:.2f}); "
             f"solid {r['solid_elements']} {r.get('solid_type', 'C3D4')} (plain {r['plain_solid_elements']}); mesh-part {r['mesh_seconds']} s "
             f"(gmsh {r['gmsh_seconds']} s)"]
    for k in ("ccx_solid", "ccx_plain_solid", "ccx_shell"):
        x = r[k]
        lines.append(f"  {k}: exit {x['exit']}, {x['errors']} errors, {x['warnings']} warnings, {x['seconds']} s {x['first_message']}")
    if "results" in r:
        w, p, d = r["results"]["whole"], r["results"]["plain"], r["results"]["relative_difference"]
        lines.append(f"  max displacement {w['max_displacement']:.4g} vs plain {p['max_displacement']:.4g} ({100 * d['max_displacement']:.1f} %)")
        for k in sorted(w["load_point_displacement"]):
            lines.append(f"  {k} load point {w['load_point_displacement'][k]:.4g} vs {p['load_point_displacement'].get(k, float('nan')):.4g}")
        lines.append(f"  max von Mises away from the features {w['max_von_mises_away']:.4g} vs {p['max_von_mises_away']:.4g} "
                     f"({100 * d['max_von_mises_away']:.1f} %, {w['nodes_away']} / {p['nodes_away']} nodes)")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--case", action="append")
    ap.add_argument("--work", default="/tmp/fe_mesh_part")
    ap.add_argument("--out")
    ap.add_argument("--linear", action="store_true", help="4-node tetrahedra (C3D4) instead of mesh-part's 10-node default")
    ap.add_argument("--size", help="element size of the rest (mesh-part --size), for every case")
    a = ap.parse_args()
    exe = os.path.join(a.build, "featureextract")
    all_rows = []
    for name, c in cases(a.build).items():
        if a.case and name not in a.case:
            continue
        if "make_feature" in c:
            if not os.path.exists(c["target"]):
                continue
            fdir = os.path.join(a.work, name + "_feature")
            subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "tools", "make_feature.py"), c["target"], fdir]
                           + c["make_feature"], check=True, capture_output=True)
            c["features"] = [fdir]
        extra = list(c.get("extra", []))
        if a.size:  # replaces the case's own size
            extra = [x for i, x in enumerate(extra) if x != "--size" and (i == 0 or extra[i - 1] != "--size")]
            extra += ["--size", a.size]
        solid_args = ["--solid"] + (["--linear"] if a.linear else [])
        res = {}
        for plain in (False, True):
            d = os.path.join(a.work, name + ("_plain" if plain else ""))
            os.makedirs(d, exist_ok=True)
            try:
                res[plain] = mesh_and_solve(exe, c["target"], c["features"], d, plain, solid_args + extra)
            except RuntimeError as e:
                res[plain] = {"error": str(e)}
        d = os.path.join(a.work, name + "_shell")
        os.makedirs(d, exist_ok=True)
        shell = mesh_and_solve(exe, c["target"], c["features"], d, False, extra)
        if "error" in res[False] or "error" in res[True]:
            row = {"case": name, "solid_error": res[False].get("error") or res[True].get("error"),
                   "instances": len(shell["instances"]), "surface_nodes": shell["mesh"]["nodes"],
                   "surface_elements": shell["mesh"]["elements"], "conformity": shell["conformity"],
                   "quality": shell["quality"], "repair": shell.get("repair"), "mesher": shell["mesher"],
                   "mesh_seconds": shell["mesh_seconds"], "ccx_shell": shell["ccx"]}
            all_rows.append(row)
            print(f"{name}: {row['instances']} instances; surface {row['surface_nodes']} nodes / {row['surface_elements']} "
                  f"elements; conformity {row['conformity']}; patches {row['quality']['patches']['inverted']} inverted; "
                  f"solid: {row['solid_error']}; ccx on the shell: exit {shell['ccx']['exit']}, "
                  f"{shell['ccx']['errors']} errors: {shell['ccx']['first_message']}")
            continue
        w = res[False]
        row = {"case": name, "instances": len(w["instances"]), "surface_nodes": w["mesh"]["nodes"],
               "surface_elements": w["mesh"]["elements"], "solid_nodes": w["solid"]["nodes"],
               "solid_elements": w["solid"]["elements"], "solid_type": w["solid"]["type"],
               "middle_nodes_on_part": w["solid"].get("middle_nodes_on_part", 0), "plain_solid_elements": res[True]["solid"]["elements"],
               "conformity": w["conformity"], "quality": w["quality"], "solid_quality": w["solid"]["quality"],
               "repair": w.get("repair"),
               "mesh_seconds": w["mesh_seconds"], "gmsh_seconds": w["mesher"].get("seconds"),
               "ccx_solid": w["ccx"], "ccx_plain_solid": res[True]["ccx"], "ccx_shell": shell["ccx"]}
        if "u" in w and "u" in res[True]:
            row["results"] = compare(w, res[True])
        all_rows.append(row)
        print(summary(row))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(all_rows, f, indent=1)


if __name__ == "__main__":
    main()
