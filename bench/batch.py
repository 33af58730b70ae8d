#!/usr/bin/python3
"""Batch throughput (issue 13): `featureextract batch` over a vault of generated and real parts, serial,
on a LocalCluster of 1 worker and of 2 workers; prints parts per minute and the ratio.

    /usr/bin/python3 bench/batch.py [--build build] [--library DIR] [--features rib,boss] [--copies N]
                                    [--variants] [--limit N] [--modes serial,1,2]

The vault: the generated models (build/models, build/models/suite) and the MFCAD parts from
../shared/data (with --real, NIST's real parts too), each copied --copies times into its own folder
(a copy has the same content: the batch stores it once more, under its own path). --variants adds,
per source part, three distinct parts made with FreeCAD: its mirror image and the part scaled 1.25x
and 0.8x about its centre (other content, other hashes: each is searched). --limit keeps the first
N parts (sources first, then mirror images, then the scaled ones). Default library: the example
plate's rib and boss (--features picks among the shipped ones). Run it alone on the machine: every
search uses both cores.
"""
import argparse
import glob
import json
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")


def vault_sources(build, real):
    parts = sorted(glob.glob(os.path.join(build, "models", "*.step")) + glob.glob(os.path.join(build, "models", "suite", "*.step")))
    parts += sorted(glob.glob(os.path.join(DATA, "mfcad", "*.step")))
    if real:  # NIST's parts: a minute or two each with the rib and the boss
        parts += sorted(glob.glob(os.path.join(DATA, "real", "*.stp")))
    return [p for p in parts if "reference" not in os.path.basename(p)]


def write_variants(sources, folder):
    """Per source part: its mirror image (about the plane x = centre) and the part scaled 1.25x and 0.8x
    about its centre, as STEP files in `folder`. Returns their paths, mirror images first."""
    sys.path.append("/usr/lib/freecad-python3/lib")
    import FreeCAD as App
    import Part
    os.makedirs(folder, exist_ok=True)
    out = {"mirror": [], "x1.25": [], "x0.8": []}
    for p in sources:
        shape = Part.read(p)
        c = shape.BoundBox.Center
        base = os.path.splitext(os.path.basename(p))[0]
        m = shape.mirror(c, App.Vector(1, 0, 0))
        path = os.path.join(folder, base + "_mirror.step")
        m.exportStep(path)
        out["mirror"].append(path)
        for f in (1.25, 0.8):
            s = shape.copy()
            s.scale(f, c)
            path = os.path.join(folder, f"{base}_x{f}.step")
            s.exportStep(path)
            out[f"x{f}"].append(path)
    return out["mirror"] + out["x1.25"] + out["x0.8"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--library", default="")
    ap.add_argument("--copies", type=int, default=1)
    ap.add_argument("--modes", default="serial,1,2")
    ap.add_argument("--out", default="")
    ap.add_argument("--real", action="store_true", help="add NIST's five real parts (slow: a minute or two each)")
    ap.add_argument("--variants", action="store_true", help="add each part's mirror image and 1.25x and 0.8x copies")
    ap.add_argument("--limit", type=int, default=0, help="keep the first N parts of the vault")
    ap.add_argument("--features", default="rib,boss", help="shipped features of the default library")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="fe_bench_batch_")
    lib = a.library
    if not lib:
        lib = os.path.join(work, "library")
        for f in a.features.split(","):
            shutil.copytree(os.path.join(ROOT, "Resources", "library", f), os.path.join(lib, f))
    src = vault_sources(a.build, a.real)
    distinct = len(src)
    if a.variants:
        t0 = time.monotonic()
        src = src + write_variants(src, os.path.join(work, "variants"))
        print(f"variants: {len(src) - distinct} parts written in {time.monotonic() - t0:.0f} s", flush=True)
    if a.limit:
        src = src[:a.limit]
    for c in range(a.copies):
        d = os.path.join(work, "vault", f"copy{c}")
        os.makedirs(d)
        for p in src:
            shutil.copy(p, os.path.join(d, os.path.basename(p)))
    n = len(src) * a.copies
    exe = os.path.join(a.build, "featureextract")
    rows = []
    for mode in a.modes.split(","):
        db = os.path.join(work, f"{mode}.sqlite")
        cmd = [exe, "batch", "--library", lib, "--parts", os.path.join(work, "vault", "**", "*.st*p"), "--db", db, "--quiet"]
        cmd += ["--serial"] if mode == "serial" else ["--workers", mode]
        t0 = time.monotonic()
        r = subprocess.run(cmd, capture_output=True, text=True)
        dt = time.monotonic() - t0
        if r.returncode != 0:
            sys.exit(f"bench/batch.py: {mode}: exit {r.returncode}: {r.stderr.strip()[-300:]}")
        con = sqlite3.connect(db)
        done, errors = con.execute("SELECT COUNT(*), SUM(1 - ok) FROM results").fetchone()
        found = con.execute("SELECT COUNT(*) FROM matches").fetchone()[0]
        con.close()
        rows.append({"mode": mode, "parts": done, "errors": errors, "instances": found, "seconds": round(dt, 1),
                     "parts_per_minute": round(done / dt * 60, 2)})
        print(f"batch {mode:>6}: {done} parts ({errors} errors, {found} instances) in {dt:.0f} s: {done / dt * 60:.1f} parts/min",
              flush=True)
    base = rows[0]["parts_per_minute"]
    for r in rows[1:]:
        print(f"  {r['mode']} vs {rows[0]['mode']}: {r['parts_per_minute'] / base:.2f}x")
    print(f"vault: {n} parts ({len(src)} distinct x {a.copies}), library {lib} ({', '.join(sorted(os.listdir(lib)))})")
    if a.out:
        with open(a.out, "w") as f:
            json.dump(rows, f, indent=1)
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
