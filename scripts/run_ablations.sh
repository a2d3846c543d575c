#!/usr/bin/env bash
# The small-scale ablations of docs/ABLATIONS.md: trains every config of
# examples/train/ablations (stage 1 from scratch, then stage 2 from that stage-1 model, which
# is also the A2P teacher) on the training pool and scores each stage-2 model on the synthetic
# benchmark; two runs at a time, one core each.
#   scripts/run_ablations.sh BENCHMARK_DIR [OMNIPOINT_BINARY]
# BENCHMARK_DIR: omnipoint synth --benchmark benchmarks/synthetic_v1.json --set final --per-split 60 --out DIR
# The pool: data/training_pool_v1 (scripts/train_default_model.sh renders it, or docs/TRAINING.md).
# Runs that already finished (their model_ema.safetensors / eval/summary.json exist) are kept.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:?usage: scripts/run_ablations.sh BENCHMARK_DIR [OMNIPOINT_BINARY]}
omnipoint=${2:-build/src/cli/omnipoint}
configs=examples/train/ablations
[[ -d data/training_pool_v1/S.FoV ]] || { echo "run_ablations: no data/training_pool_v1 (see docs/TRAINING.md)" >&2; exit 1; }

train() {  # NAME
  if [[ ! -f runs/ablations/$1/model_ema.safetensors ]]; then
    echo "== train $1"
    mkdir -p runs/ablations
    "$omnipoint" train --config "$configs/$1.json" > "runs/ablations/$1.log" 2>&1 || true
    [[ -f runs/ablations/$1/model_ema.safetensors ]] || { echo "run_ablations: $1 did not finish (runs/ablations/$1.log)" >&2; return 1; }
  fi
}
score() {  # NAME
  if [[ ! -f runs/ablations/$1/eval/summary.json ]]; then
    echo "== eval $1"
    "$omnipoint" eval --model "runs/ablations/$1/model_ema.safetensors" --data "$data" --intrinsics \
      --sparse-depth 100 --num-tokens 16 --threads 1 --label "$1" --out "runs/ablations/$1/eval" > /dev/null 2> "runs/ablations/$1/eval.log"
  fi
}
stage2() { train "$1" && score "$1"; }  # NAME
lineage() { train "s1_$1" && stage2 "s2_$1"; }  # SUFFIX: a stage 1 and the stage 2 from it

# Two jobs at a time.
pool() {  # FUNCTION NAME...
  local fn=$1 failed=0
  shift
  for name in "$@"; do
    while (( $(jobs -rp | wc -l) >= 2 )); do wait -n || failed=1; done
    "$fn" "$name" &
  done
  while (( $(jobs -rp | wc -l) > 0 )); do wait -n || failed=1; done
  return $failed
}
# The base's three seeds first (the spread every variant is read against), then the variants
# with their own stage 1, then those that fine-tune the base's seed-0 stage-1 model.
pool lineage base_seed0 base_seed1 base_seed2 xyz naive disjoint
pool stage2 s2_no_p2a_no_a2p s2_p2a_only s2_a2p_only s2_no_smoothing s2_no_state_embeddings
