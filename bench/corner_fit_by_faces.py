#!/usr/bin/python3
"""Where each match of the development case occt_cooker_corners puts the reference's own corner
faces (the quarter torus and quarter cylinder) and its context (hob top, straight edge fillet,
worktop), as distances to the target's surface; with the match's face_shares and its label.

    bench/user_cases.py --only dev --cases occt_cooker_corners --evidence --work W --out ROWS.json
    freecadcmd -c "import sys; sys.argv = ['x', 'W', 'ROWS.json', 'stl_plain']; exec(open('bench/corner_fit_by_faces.py').read())"

Runs: STYLE_VARIANT for the styles box and stl and the variants plain, mirror and stretch (the
reference is not scaled there, so its points can be labelled by the part's corner faces). Up to 300
points of each kind per match; distances by OCCT's distToShape. Twenty-ninth/thirtieth sessions'
question: does anything about the reference's own faces tell a true corner from a fit slid along a
straight edge? (docs/benchmarks.md, "Thirtieth session")."""
import json
import os
import random
import sys

sys.path.insert(0, "bench")  # (run from the checkout)
import user_cases as U  # noqa: E402

import FreeCAD as App  # noqa: E402
import Mesh  # noqa: E402
import Part  # noqa: E402

COOKER = "/usr/share/opencascade/data/occ/MODERN_Cooker_1.brep"
work, rows_path, run = sys.argv[1], sys.argv[2], sys.argv[3]
style, variant = run.split("_")
part = Part.read(COOKER)
own = Part.Compound([part.getElement(f) for f in U.cooker_corners(COOKER)[0]])
base = os.path.join(work, "occt_cooker_corners")
target = part if variant == "plain" else Part.read(f"{base}_{variant}.brep")
result = json.load(open(f"{base}_{run}.json"))
row = [r for r in json.load(open(rows_path)) if r["style"] == style and r["variant"] == variant][0]
labels = [e["true"] for e in row["evidence"]]

points = []  # triangle centroids of the reference
if style == "stl":
    for f in Mesh.Mesh(f"{base}_{run}.stl").Facets:
        points.append(App.Vector(*[sum(p[i] for p in f.Points) / 3 for i in range(3)]))
else:
    for f in Part.read(f"{base}_{run}.brep").Faces:
        v, t = f.tessellate(0.02)
        points += [(v[a] + v[b] + v[c]) * (1 / 3) for a, b, c in t]
on_own = [own.distToShape(Part.Vertex(p))[0] < 0.02 for p in points]
random.seed(1)
mine = [i for i, o in enumerate(on_own) if o]
mine = mine[:: max(1, len(mine) // 300)]
context = random.sample([i for i, o in enumerate(on_own) if not o], min(300, len(on_own) - sum(on_own)))


def quantile(v, a):
    v = sorted(v)
    return v[min(len(v) - 1, int(a * len(v)))]


print(f"{run}: {len(points)} reference points, {sum(on_own)} on the corner's own faces; L = {result['feature_size']:.2f} mm")
for m, true in zip(result["matches"], labels):
    H = m["transform"]

    def off(i):
        x = (points[i].x, points[i].y, points[i].z, 1.0)
        y = [sum(H[r][c] * x[c] for c in range(4)) for r in range(4)]
        return target.distToShape(Part.Vertex(App.Vector(y[0] / y[3], y[1] / y[3], y[2] / y[3])))[0]

    d_own, d_ctx = [off(i) for i in mine], [off(i) for i in context]
    print(f"  {'true ' if true else 'false'} at {[round(c, 1) for c in m['center']]} face_shares {m['face_shares']}: "
          f"own faces median {quantile(d_own, .5):.3f} q90 {quantile(d_own, .9):.3f} max {max(d_own):.3f} mm; "
          f"context median {quantile(d_ctx, .5):.3f} q90 {quantile(d_ctx, .9):.3f} mm")
