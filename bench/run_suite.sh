#!/usr/bin/env bash
# The benchmark suite in one command: installs what the peers and the plot need (Debian packages),
# builds, generates the suite and scaling models, runs our engine and the peers on every case, and
# writes the tables and plot into docs/benchmarks.md (between the suite markers) and docs/images/.
#   bench/run_suite.sh [suite.py options, e.g. --cases five_ribs bosses --methods ours open3d]
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${FE_BUILD_DIR:-build}
tools/install_packages.sh python3-open3d python3-scipy python3-matplotlib time
[ -f "$BUILD/CMakeCache.txt" ] || ./setup.sh
cmake --build "$BUILD" -j2 >/dev/null
REAL="$(pwd)/../shared/data/real"   # the real parts beside the checkout (not copied into the repo)
[ -d "$REAL" ] || { echo "run_suite: $REAL not found: the real-part case is skipped" >&2; REAL=""; }
"$BUILD/fe_make_models" "$BUILD/models" --suite ${REAL:+--real "$REAL"} --scaling >/dev/null
exec /usr/bin/python3 bench/suite.py --build "$BUILD" "$@"
