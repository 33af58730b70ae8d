#!/usr/bin/python3
"""What searching one part with a library of N features costs against one feature (issue 13's goal:
20 features for at most 3 times one), with the feature sizes rounded to the size ladder (the library
search's default, size_ladder 3) and without it (size_ladder 0, every feature described at its own size).

    /usr/bin/python3 bench/library_scale.py [--build build] [--features 20] [--repeat 1] [--out JSON] [--set NAME=VALUE]

The library is made the way a user makes one, `featureextract library add` of labelled faces: the
first instance of the labelled class of each MFCAD part (../shared/data/mfcad, MIT licence) after the
target part, the first part of its index. Run it alone on the machine: it prints seconds.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MFCAD = os.path.join(ROOT, "..", "shared", "data", "mfcad")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"library_scale.py: {' '.join(cmd)}: exit {r.returncode}: {r.stderr.strip()[-300:]}")
    return r


def make_library(exe, folder, parts, n):
    os.makedirs(folder, exist_ok=True)
    made = 0
    for part in parts:
        if made == n:
            break
        labels = json.load(open(os.path.join(MFCAD, part["file"].replace(".step", ".labels.json"))))
        inst = [i for i in labels["instances"] if i["class"] == part["target_class"]]
        if not inst:
            continue
        faces = ",".join(f.replace("Face", "") for f in inst[0]["faces"])
        name = f"{part['target_class']} of {part['file'][:-5]}"
        run([exe, "library", "add", folder, "--from", os.path.join(MFCAD, part["file"]), "--faces", faces, "--name", name,
             "--class", part["target_class"], "--folder", f"f{made:02d}", "--replace"])
        made += 1
    return made


def search(exe, library, target, ladder, overrides=()):
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as t:
        out = t.name
    run([exe, "search", "--library", library, "--target", target, "--output", out, "--set", f"size_ladder={ladder}",
         *[x for kv in overrides for x in ("--set", kv)]])
    r = json.load(open(out))
    os.unlink(out)
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--features", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--work", default=None, help="folder for the libraries (default: a temporary one)")
    ap.add_argument("--out", default=None)
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="engine parameter for every search (A/B runs)")
    a = ap.parse_args()
    exe = os.path.join(a.build, "featureextract")
    parts = json.load(open(os.path.join(MFCAD, "index.json")))["parts"]
    target = os.path.join(MFCAD, parts[0]["file"])
    work = a.work or tempfile.mkdtemp(prefix="fe_library_scale_")
    one, many = os.path.join(work, "one"), os.path.join(work, "many")
    if make_library(exe, one, parts[1:], 1) != 1 or make_library(exe, many, parts[1:], a.features) != a.features:
        sys.exit("library_scale.py: not enough labelled MFCAD parts for the library")
    rows = {}
    for label, lib, ladder in (("1 feature", one, 3), (f"{a.features} features, size_ladder 0", many, 0),
                               (f"{a.features} features, size_ladder 3", many, 3)):
        runs = [search(exe, lib, target, ladder, a.set) for _ in range(a.repeat)]
        r = runs[0]
        rows[label] = {"seconds": [x["seconds"] for x in runs], "median": statistics.median(x["seconds"] for x in runs),
                       "descriptions": r["descriptions_built"], "tessellations": r["tessellations"],
                       "matches": {f["name"]: len(f["matches"]) for f in r["features"]},
                       "ransac_searches": sum(f.get("ransac_searches", 0) for f in r["features"]),
                       "errors": sum(1 for f in r["features"] if f["error"])}
    base = rows["1 feature"]["median"]
    print(f"target {os.path.basename(target)}; library: {a.features} MFCAD features; seconds are medians of {a.repeat}")
    print("| search | seconds | vs one feature | target descriptions | tessellations | RANSAC searches | instances found | features refused |")
    print("|---|---|---|---|---|---|---|---|")
    for label, r in rows.items():
        print(f"| {label} | {r['median']:.1f} | {r['median'] / base:.1f}x | {r['descriptions']} | {r['tessellations']} | "
              f"{r['ransac_searches']} | {sum(r['matches'].values())} | {r['errors']} |")
    a0, a3 = rows[f"{a.features} features, size_ladder 0"]["matches"], rows[f"{a.features} features, size_ladder 3"]["matches"]
    diff = {k: (a0[k], a3[k]) for k in a0 if a0[k] != a3.get(k)}
    print(f"features whose instance count differs between size_ladder 0 and 3: {len(diff)} {diff if diff else ''}")
    if a.out:
        json.dump(rows, open(a.out, "w"), indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
