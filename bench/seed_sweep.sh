#!/usr/bin/env bash
# Recall over seeds: runs the CLI on the generated cases for seeds 1..N (default 20) and prints,
# per case, how many seeds gave the expected number of instances. A benchmark, not a test.
#   bench/seed_sweep.sh [N] [BUILD_DIR]
set -euo pipefail
N=${1:-20}
B=${2:-build}
M="$B/models"
cases=(
  "rib_reference.step ribs_bosses.step 5"
  "rib_wide_reference.brep ribs_bosses.step 5"
  "rib_reference.step scaled_ribs.step 5"
  "rib_reference.step ribs_bosses_cracked.stl 5"
  "rib_reference.step ribs_bosses_rotated.step 5"
  "rib_reference.step boss_only.step 0"
)
echo "| reference | target | expected | seeds giving it (of $N) | median s |"
echo "|---|---|---|---|---|"
for c in "${cases[@]}"; do
  set -- $c
  ok=0
  times=()
  for s in $(seq 1 "$N"); do
    "$B/featureextract" extract -q -r "$M/$1" -t "$M/$2" -o /tmp/fe_sweep.json --seed "$s"
    read -r n t < <(/usr/bin/python3 -c "import json; r = json.load(open('/tmp/fe_sweep.json')); print(len(r['matches']), r['timings']['total'])")
    [ "$n" = "$3" ] && ok=$((ok + 1))
    times+=("$t")
  done
  med=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {printf "%.2f", a[int((NR+1)/2)]}')
  echo "| $1 | $2 | $3 | $ok | $med |"
done
