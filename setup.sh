#!/usr/bin/env bash
# Sets FeatureExtract up on a fresh Debian bookworm machine and runs the main job on the bundled
# example: installs the Debian packages, builds (Release, -j2), generates the example models and
# finds the ribs of the example plate. Safe to run again (each step is incremental).
#   ./setup.sh            everything
#   FE_SKIP_APT=1 ./setup.sh   when the packages are already there
set -euo pipefail
cd "$(dirname "$0")"
BUILD=${FE_BUILD_DIR:-build}

PACKAGES=(
  build-essential cmake pkg-config
  libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev libocct-data-exchange-dev
  libpcl-dev libboost-dev libnanoflann-dev libeigen3-dev nlohmann-json3-dev libcli11-dev libgtest-dev libbenchmark-dev
  python3 python3-numpy python3-pytest pybind11-dev python3-pybind11
  freecad xvfb xauth
  clang libclang-rt-14-dev   # libFuzzer and the sanitizers: the fuzzing build (fuzz/, issue 10)
  occt-misc   # real parts for bench/user_cases.py (Top.brep)
  gmsh python3-gmsh calculix-ccx   # mesh-part: gmsh meshes the rest of the part (a separate program), CalculiX solves it (issue 12)
  python3-distributed python3-psycopg2 python3-matplotlib postgresql   # library search, batch on Dask into SQLite/PostgreSQL, thumbnails (issue 13)
)
[ -n "${FE_SKIP_APT:-}" ] || tools/install_packages.sh "${PACKAGES[@]}"

cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DPython_EXECUTABLE=/usr/bin/python3 >/dev/null
cmake --build "$BUILD" -j2
# the fuzz targets (clang, libFuzzer, ASan + UBSan over the readers), run by ctest's fuzz_readers
cmake -S fuzz -B "$BUILD/fuzz" -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build "$BUILD/fuzz" -j2

"$BUILD/fe_make_models" "$BUILD/models"

# The FreeCAD workbench: a link in the user's Mod folder (FreeCAD 0.20's XDG location). It finds the
# Python module in $BUILD/python through the link's real path.
MOD="${XDG_DATA_HOME:-${HOME:-/root}/.local/share}/FreeCAD/Mod"
mkdir -p "$MOD"
ln -sfn "$(pwd)/FeatureExtractWB" "$MOD/FeatureExtract"
echo "setup: FreeCAD workbench linked: $MOD/FeatureExtract -> $(pwd)/FeatureExtractWB"
echo "setup: main job: find the reference rib on the example plate (5 ribs of different widths, 2 bosses)"
"$BUILD/featureextract" extract \
  --reference "$BUILD/models/rib_reference.step" \
  --target "$BUILD/models/ribs_bosses.step" \
  --output "$BUILD/example_result.json"
/usr/bin/python3 - "$BUILD/example_result.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"setup: {len(r['matches'])} instances found in {r['timings']['total']:.1f} s -> {sys.argv[1]}")
for i, m in enumerate(r["matches"], 1):
    c = ", ".join(f"{x:.1f}" for x in m["center"])
    print(f"  #{i}: center ({c}) scale {m['scale']:.2f} score {m['score']:.2f} "
          f"fit error {m['rms_error']:.2f} mm, faces {m['faces'][:6]}{'...' if len(m['faces']) > 6 else ''}")
PY
