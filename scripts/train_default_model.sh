#!/usr/bin/env bash
# How the bundled model (models/omnipoint_default.safetensors) is made; docs/TRAINING.md,
# "The bundled model".
#   scripts/train_default_model.sh [OMNIPOINT_BINARY]
# 1. Renders the training pool (benchmarks/training_pool_v1.json, 20,000 samples, ~31 minutes on
#    2 cores) into data/training_pool_v1/, two shards side by side; an interrupted render resumes.
# 2. Trains examples/train/default_model/omnipoint_default<SUFFIX>.json into
#    runs/default_model<SUFFIX>/ for each SUFFIX in turn on two data-parallel ranks (one core
#    each), every run after the first starting from the previous run's EMA weights: "" from
#    scratch (48,000 images), _longer (84,000 more), then _finetune to _finetune6 at lower rates
#    with the pinhole bucket drawn more often (50,400, 37,600, 65,600, 56,000, 48,000 and 19,200
#    more). The fourth to sixth fine-tunes start from those weights stored as F16 (the file that
#    was bundled when they ran; the fp32 files were lost), so this script makes those copies too.
#    A finished run is kept; an interrupted one resumes from its last checkpoint.
# 3. Ships the final EMA weights as F16.
set -euo pipefail
cd "$(dirname "$0")/.."
omnipoint=${1:-build/src/cli/omnipoint}

"$omnipoint" synth --definition benchmarks/training_pool_v1.json --set train --core-files \
  --threads 1 --shard 0/2 --out data/training_pool_v1 > /dev/null &
"$omnipoint" synth --definition benchmarks/training_pool_v1.json --set train --core-files \
  --threads 1 --shard 1/2 --out data/training_pool_v1 > /dev/null
wait

train() {  # SUFFIX; a finished run (its final EMA weights written) is kept
  local run=runs/default_model$1
  [[ -f $run/model_ema.safetensors ]] && return
  local resume=()
  [[ -e $run/checkpoints/latest ]] && resume=(--resume "$run")
  "$omnipoint" train --config "examples/train/default_model/omnipoint_default$1.json" --nproc 2 \
    "${resume[@]}"
}
ema_as_f16() {  # SUFFIX [DESTINATION]; the run's EMA weights as F16
  local run=runs/default_model$1
  /usr/bin/python3 tools/safetensors_to_f16.py "$run/model_ema.safetensors" \
    "${2:-$run/model_ema_f16.safetensors}"
}

for suffix in "" _longer _finetune _finetune2 _finetune3; do
  train "$suffix"
done
for n in 4 5 6; do
  ema_as_f16 "_finetune$((n - 1))"
  train "_finetune$n"
done
ema_as_f16 _finetune6 models/omnipoint_default.safetensors
