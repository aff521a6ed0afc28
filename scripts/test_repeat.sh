#!/usr/bin/env bash
# Runs the suite (both passes, no lint or coverage) N times and names every test that ever failed,
# with how often: a flaky test shows here long before it fails someone's CI.
#   scripts/test_repeat.sh N [pytest arguments…]   (the arguments go to every pytest run)
# HOG=1 runs a CPU hog beside every run (stress-ng --cpu 1, Debian's package): the suite must stay
# green on a busy machine.
set -uo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
shift $(($# > 0 ? 1 : 0))
out=var/test-repeat
rm -rf "$out" && mkdir -p "$out"
if [ "${HOG:-0}" = 1 ]; then
  stress-ng --cpu 1 --quiet &
  hog_pid=$!
  trap 'kill "$hog_pid" 2>/dev/null; wait "$hog_pid" 2>/dev/null' EXIT
  echo "A CPU hog beside every run: stress-ng --cpu 1 (pid $hog_pid)"
fi
green=0
for i in $(seq 1 "$runs"); do
  start=$SECONDS
  if TEST_LINT=0 TEST_COVERAGE=0 bash scripts/test.sh "$@" > "$out/run-$i.log" 2>&1; then
    green=$((green + 1)); verdict=green
  else
    verdict=red
  fi
  echo "run $i of $runs: $verdict in $((SECONDS - start)) s ($out/run-$i.log)"
done
echo
echo "test_repeat_green: $green of $runs"
[ "${HOG:-0}" = 1 ] && echo "make_test_busy_green_runs: $green of $runs"
# pytest's short summary (-ra) names each failed or erroring test once per pass.
failures=$(grep -hoE "^(FAILED|ERROR) [^ ]+" "$out"/run-*.log | sort | uniq -c | sort -rn)
if [ -n "$failures" ]; then
  echo "Tests that failed at least once (count, over $runs runs of both passes):"
  echo "$failures"
else
  echo "No test failed in any run."
fi
[ "$green" = "$runs" ]
