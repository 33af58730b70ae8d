#!/usr/bin/python3
"""Adds the library's features taken from real and labelled parts (issue 13) to Resources/library, the
way a user adds one: `featureextract library add LIB --from PART --faces ... --name ...`.

    /usr/bin/python3 tools/make_library.py [--build build] [--library Resources/library]

Sources (../shared/data, see its READMEs): NIST CTC-02, FTC-06 and FTC-10 (US Government works,
public domain) and MFCAD part 5-5-5-5-12-23 (MIT licence, Copyright (c) 2020 hducg; the notice is
kept in the feature's description). The faces are FreeCAD FaceN numbers of those files.
"""
import argparse
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")

FEATURES = [
    # folder, part, faces, name, class, rigid faces, element size, description
    ("mounting_lug", "real/nist_ctc_02_asme1_rc.stp", "197,198,199,229", "mounting lug", "lug", "198,199", 10,
     "NIST CTC-02's mounting lug (top, bolt hole, outer R30 arc); its six lugs are mirror images three by three"),
    ("corner_ear", "real/nist_ftc_10_asme1_rb.stp", "33,36,37,38,43,44,45,93,110,124,125,126", "corner ear", "ear", "", None,
     "NIST FTC-10's corner ear; the four are mirror images two by two"),
    ("counterbored_hole", "real/nist_ftc_06_asme1_rd.stp", "60,61,62", "counterbored hole", "hole", "60", None,
     "NIST FTC-06's counterbored bolt hole (R7.1 hole, R10.3 counterbore and its floor); the bolt hole's nodes are a rigid bolt connection"),
    ("through_slot", "mfcad/5-5-5-5-12-23.step", "3,17,18", "rectangular through slot", "slot", "", None,
     "MFCAD part 5-5-5-5-12-23's rectangular through slot (MFCAD: MIT licence, Copyright (c) 2020 hducg)"),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--library", default=os.path.join(ROOT, "Resources", "library"))
    a = ap.parse_args()
    exe = os.path.join(a.build, "featureextract")
    for folder, part, faces, name, cls, rigid, size, text in FEATURES:
        cmd = [exe, "library", "add", a.library, "--from", os.path.join(DATA, part), "--faces", faces, "--name", name,
               "--class", cls, "--description", text, "--folder", folder, "--replace"]
        if rigid:
            cmd += ["--rigid-faces", rigid]
        if size:
            cmd += ["--size", str(size)]
        r = subprocess.run(cmd)
        if r.returncode != 0:
            sys.exit(f"make_library.py: {name}: library add failed (exit {r.returncode})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
