#!/usr/bin/env bash
# Writing a 12 MP prediction's files (bench_outputs at 4000x3000), two builds side by side:
#   bench/outputs_side_by_side.sh BUILD_A BUILD_B [ROUNDS]   (default 3 rounds)
# Each round runs every 4000x3000 benchmark of A, then of B, each in its own process after a
# pause: on a VM that returns freed memory to its host, the page cache's first write into a
# returned page costs a host fault, so every run starts from the same (cold) state.
# (docs/PERFORMANCE.md, "Concurrent writing".)
set -euo pipefail
[[ $# -ge 2 ]] || { sed -n 2,3p "$0" >&2; exit 2; }
rounds=${3:-3}
pause=${PAUSE_S:-25}
uptime
for round in $(seq "$rounds"); do
  for build in "$1" "$2"; do
    program="$build/bench/bench_outputs"
    for name in $("$program" --benchmark_list_tests --benchmark_filter=4000); do
      sleep "$pause"
      # The benchmark's own thread argument, where it has one, wins over OMP_NUM_THREADS.
      echo -n "round $round $build "
      OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive "$program" --benchmark_filter="^${name}\$" 2>&1 |
        grep '^BM_' | tr -s ' ' | cut -d' ' -f1,2,4
    done
  done
done
uptime
