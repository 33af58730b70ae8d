#!/usr/bin/env bash
# Runs every fuzz target (issue 10) for SECONDS each on generated seeds, then every regression input
# once: fuzz/regressions/<kind>/ (inputs that once failed) and ../shared/data/bad-input (files that
# crashed or hung earlier builds). Fails on any crash, sanitizer report, uncaught exception or input
# over the time limit. Prints one line per target: runs, new corpus entries, findings.
#   fuzz/run.sh FUZZ_BUILD_DIR [SECONDS] [KINDS...]
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "$1" && pwd)
seconds=${2:-15}
shift 2 2>/dev/null || shift $#
kinds=${*:-stl obj ply step iges brep inp msh feature params extract}
bad="$here/../../shared/data/bad-input"
work=$(mktemp -d /tmp/fe_fuzz_run.XXXXXX)
trap 'rm -rf "$work"' EXIT
export FE_FUZZ_TMP="$work" FE_FUZZ_FEATURE="$here/../Resources/library/rib"
# fuzz_extract's fixed partners: the reference when the input is the target, and the other way round
export FE_FUZZ_REFERENCE="$work/seeds/extract_fixed/reference.stl" FE_FUZZ_TARGET="$work/seeds/extract_fixed/target.stl"
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
/usr/bin/python3 "$here/make_corpus.py" "$work/seeds" >/dev/null || { echo "fuzz: cannot make the seed corpus"; exit 1; }
status=0
for kind in $kinds; do
  exe="$build/fuzz_$kind"
  [ -x "$exe" ] || { echo "fuzz: $exe missing (build it: see fuzz/CMakeLists.txt)"; status=1; continue; }
  mkdir -p "$work/corpus/$kind" "$work/crash"
  cp "$work/seeds/$kind"/* "$work/corpus/$kind"/
  seeds=$(ls "$work/corpus/$kind" | wc -l)
  # -timeout: a CAD read is stopped at 2 s in the target, so 30 s means a hang outside it
  "$exe" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=4096 -max_len=100000 -print_final_stats=1 \
         -artifact_prefix="$work/crash/$kind-" "$work/corpus/$kind" >"$work/$kind.log" 2>&1
  rc=$?
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$work/$kind.log" | grep -o '[0-9]*$' | tail -1)
  new=$(( $(ls "$work/corpus/$kind" | wc -l) - seeds ))
  # the regression inputs, each once
  reg=()
  [ -d "$here/regressions/$kind" ] && for f in "$here/regressions/$kind"/*; do [ -f "$f" ] && reg+=("$f"); done
  case $kind in
    step) reg+=("$bad"/step_*.step) ;;
    brep) reg+=("$bad"/brep_*.brep) ;;
    stl|extract) reg+=("$bad"/*.stl) ;;
    obj) reg+=("$bad"/*.obj) ;;
    ply) reg+=("$bad"/*.ply) ;;
    feature) reg+=("$bad"/feature_*/feature.json) ;;
  esac
  rrc=0
  if [ ${#reg[@]} -gt 0 ]; then
    "$exe" -timeout=60 -rss_limit_mb=4096 "${reg[@]}" >"$work/$kind.reg.log" 2>&1
    rrc=$?
  fi
  verdict=ok
  if [ $rc -ne 0 ] || [ $rrc -ne 0 ] || [ -z "$runs" ]; then
    verdict=FAILED
    status=1
  fi
  printf 'fuzz: %-8s %7s inputs in %s s, %4d new corpus entries, %2d regression inputs: %s\n' "$kind" "${runs:-?}" "$seconds" "$new" "${#reg[@]}" "$verdict"
  if [ "$verdict" = FAILED ]; then
    grep -E 'ERROR|SUMMARY|Test unit written|timeout|uncaught|deadly' "$work/$kind.log" "$work/$kind.reg.log" 2>/dev/null | head -8 | sed 's/^/fuzz:   /'
    ls "$work/crash" 2>/dev/null | sed 's/^/fuzz:   artifact: /'
    mkdir -p "$build/findings" && cp "$work/crash"/* "$build/findings"/ 2>/dev/null
  fi
done
exit $status
