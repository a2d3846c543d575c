#!/usr/bin/env bash
# Training throughput of two builds side by side: rounds of A then B, each a fresh
# `omnipoint train` stopped after a number of steps, the training loop's images/s (the last log
# record's, which leaves out the start-up) compared round by round. docs/PERFORMANCE.md
# ("Training throughput") has the results; bench/train_default_before_issue16.json is its A side.
#   bench/train_side_by_side.sh A_BINARY A_CONFIG A_ARGS B_BINARY B_CONFIG B_ARGS STEPS_A STEPS_B [ROUNDS=3]
# A_ARGS / B_ARGS: extra arguments of `train` (e.g. "--nproc 2"; "" for none). Each run trains a
# copy of its config whose output_dir is a fresh temporary folder: the configs' own runs are kept.
set -euo pipefail
if (( $# < 8 )); then
  sed -n 2,9p "$0" >&2
  exit 2
fi
a_bin=$1 a_config=$2 a_args=$3 b_bin=$4 b_config=$5 b_args=$6 a_steps=$7 b_steps=$8 rounds=${9:-3}

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

rate() {  # BINARY CONFIG ARGS STEPS -> images/s of the training loop
  rm -rf "$work/run"
  /usr/bin/python3 -c '
import json, sys
config = json.load(open(sys.argv[1]))
config["output_dir"] = sys.argv[3]
json.dump(config, open(sys.argv[2], "w"))' "$2" "$work/config.json" "$work/run"
  # shellcheck disable=SC2086
  "$1" train --config "$work/config.json" $3 --stop-after "$4" > /dev/null 2>&1
  /usr/bin/python3 -c '
import json, sys
records = [json.loads(l) for l in open(sys.argv[1]) if "images_per_s" in l]
print("%.3f" % records[-1]["images_per_s"])' "$work/run/log.jsonl"
}

echo "round  A images/s  B images/s  B/A"
ratios=()
for round in $(seq 1 "$rounds"); do
  a=$(rate "$a_bin" "$a_config" "$a_args" "$a_steps")
  b=$(rate "$b_bin" "$b_config" "$b_args" "$b_steps")
  ratio=$(/usr/bin/python3 -c "print(f'{$b / $a:.2f}')")
  ratios+=("$ratio")
  printf '%5d  %10s  %10s  %s\n' "$round" "$a" "$b" "$ratio"
done
/usr/bin/python3 -c "
import statistics, sys
r = [float(x) for x in sys.argv[1:]]
print(f'median B/A {statistics.median(r):.2f} (min {min(r):.2f}, max {max(r):.2f}) over {len(r)} rounds')" "${ratios[@]}"
