#!/usr/bin/python3
"""Speed on a real part (issue 9 goal: NIST CTC-02 with a lug reference in <= 5 s end to end on 2
cores). Picks one mounting lug's faces as the reference (as in bench/user_cases.py), runs the CLI
--repeats times and prints the median wall time, the stages of the median run and what was found.

    /usr/bin/python3 bench/real_part_speed.py [--build build] [--repeats 3]

Time it alone: the machine has 2 cores and the engine uses both.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import user_cases  # noqa: E402  (FreeCAD's Part, the CTC-02 lug ground truth)

Part = user_cases.Part


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(user_cases.ROOT, "build"))
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    target = os.path.join(user_cases.SHARED, "real", "nist_ctc_02_asme1_rc.stp")
    lugs = user_cases.ctc02_lugs(target)
    work = tempfile.mkdtemp(prefix="fe_speed_")
    ref = user_cases.make_reference(Part.read(target), lugs[0], "faces", work, "ctc02_lug")
    out = os.path.join(work, "out.json")
    runs = []
    for _ in range(a.repeats):
        t0 = time.monotonic()
        subprocess.run([os.path.join(a.build, "featureextract"), "extract", "--reference", ref, "--target", target,
                        "--output", out, "--quiet"], check=True)
        runs.append((time.monotonic() - t0, json.load(open(out))))
    runs.sort(key=lambda r: r[0])
    wall, res = runs[len(runs) // 2]
    tp, fp = user_cases.score(res, Part.read(target), lugs)[:2]
    print(f"NIST CTC-02 ({res['target']['faces']} faces), lug reference ({res['reference']['faces']} faces): "
          f"median {wall:.1f} s of {a.repeats} (all: {', '.join(f'{r[0]:.1f}' for r in sorted(runs, key=lambda r: r[0]))}); "
          f"{tp} of {len(lugs)} lugs found, {fp} false")
    stages = sorted(((k, v) for k, v in res["timings"].items() if k != "total"), key=lambda kv: -kv[1])
    print("stages (median run): " + ", ".join(f"{k} {v:.2f} s" for k, v in stages if v >= 0.05))


if __name__ == "__main__":
    main()
