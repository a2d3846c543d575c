#!/usr/bin/env bash
# The library's default threads (util/threads.h) against LibTorch's own default, side by side:
#   bench/threads_default.sh BUILD [ROUNDS] [FILTER]   (default 5 rounds, P2A 1 MP -> 2048x1024)
# A program that links the library and sets nothing now computes on every core; before, it
# got LibTorch's default, the machine's physical cores (one on this 2-vCPU machine), which
# OMP_NUM_THREADS=1 reproduces here. Each round runs the benchmark both ways, alternating which
# goes first; the figure is the benchmark's own time (docs/PERFORMANCE.md, "Threads").
set -euo pipefail
[[ $# -ge 1 ]] || { sed -n 2,2p "$0" >&2; exit 2; }
program="$1/bench/bench_augment"
rounds=${2:-5}
filter=${3:-'^BM_P2A_Panorama2048/0/real_time$'}
uptime
run() {  # $1: label, then the environment to run under
  local label=$1
  shift
  echo -n "$label "
  env "$@" "$program" --benchmark_filter="$filter" 2>&1 | grep -E '^(BM_|threads)' | tr -s ' ' |
    tr '\n' ' '
  echo
}
for round in $(seq "$rounds"); do
  if (( round % 2 )); then
    run "library-default" -u OMP_NUM_THREADS
    run "libtorch-default" OMP_NUM_THREADS=1
  else
    run "libtorch-default" OMP_NUM_THREADS=1
    run "library-default" -u OMP_NUM_THREADS
  fi
done
uptime
