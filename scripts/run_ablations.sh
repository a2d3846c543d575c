#!/usr/bin/env bash
# The small-scale ablations of docs/ABLATIONS.md: trains every config of
# examples/train/ablations (stage 1 from scratch, then stage 2 from that stage-1 model, which
# is also the A2P teacher) and scores each stage-2 model on the synthetic benchmark.
#   scripts/run_ablations.sh BENCHMARK_DIR [OMNIPOINT_BINARY]
# BENCHMARK_DIR: omnipoint synth --benchmark benchmarks/synthetic_v1.json --set final --per-split 60 --out DIR
# Runs that already finished (their model_ema.safetensors / eval/summary.json exist) are kept.
set -euo pipefail
cd "$(dirname "$0")/.."
data=${1:?usage: scripts/run_ablations.sh BENCHMARK_DIR [OMNIPOINT_BINARY]}
omnipoint=${2:-build/src/cli/omnipoint}
configs=examples/train/ablations

train() {  # NAME
  if [[ ! -f runs/ablations/$1/model_ema.safetensors ]]; then
    echo "== train $1"
    "$omnipoint" train --config "$configs/$1.json" 2>&1 | grep -v "^train: step" || true
    [[ -f runs/ablations/$1/model_ema.safetensors ]] || { echo "run_ablations: $1 did not finish" >&2; exit 1; }
  fi
}
score() {  # NAME
  if [[ ! -f runs/ablations/$1/eval/summary.json ]]; then
    echo "== eval $1"
    "$omnipoint" eval --model "runs/ablations/$1/model_ema.safetensors" --data "$data" --intrinsics \
      --sparse-depth 100 --num-tokens 16 --label "$1" --out "runs/ablations/$1/eval" > /dev/null 2> "runs/ablations/$1/eval.log"
  fi
}

# The variants first (each against seed 0), then the other seeds of the base for the spread.
train s1_base_seed0; train s2_base_seed0; score s2_base_seed0
for variant in no_p2a_no_a2p p2a_only a2p_only no_smoothing no_state_embeddings; do
  train s2_$variant; score s2_$variant
done
for variant in xyz naive disjoint; do train s1_$variant; train s2_$variant; score s2_$variant; done
for seed in 1 2; do train s1_base_seed$seed; train s2_base_seed$seed; score s2_base_seed$seed; done
