#!/usr/bin/env bash
# How the bundled model (models/omnipoint_default.safetensors) is made; docs/TRAINING.md,
# "The bundled model".
#   scripts/train_default_model.sh [OMNIPOINT_BINARY]
# 1. Renders the training pool (benchmarks/training_pool_v1.json, 20,000 samples, ~31 minutes on
#    2 cores) into data/training_pool_v1/, two shards side by side; an interrupted render resumes.
# 2. Trains examples/train/default_model/omnipoint_default.json on two data-parallel ranks (one
#    core each) into runs/default_model/ (48,000 images), then continues from its EMA weights
#    with omnipoint_default_longer.json into runs/default_model_longer/ (84,000 more), then
#    fine-tunes that with omnipoint_default_finetune.json into runs/default_model_finetune/
#    (50,400 more), that with omnipoint_default_finetune2.json into
#    runs/default_model_finetune2/ (37,600 more), that with omnipoint_default_finetune3.json
#    into runs/default_model_finetune3/ (65,600 more) and, from that run's EMA weights stored as
#    F16 (the file bundled before it), with omnipoint_default_finetune4.json into
#    runs/default_model_finetune4/ (56,000 more) and, from that one's EMA weights as F16, with
#    omnipoint_default_finetune5.json into runs/default_model_finetune5/ (48,000 more) and, from
#    that one's EMA weights as F16 (the file bundled before it), with
#    omnipoint_default_finetune6.json into runs/default_model_finetune6/ (19,200 more); an
#    interrupted run resumes from its last checkpoint.
# 3. Ships the final EMA weights as F16.
set -euo pipefail
cd "$(dirname "$0")/.."
omnipoint=${1:-build/src/cli/omnipoint}
config=examples/train/default_model/omnipoint_default.json

"$omnipoint" synth --definition benchmarks/training_pool_v1.json --set train --core-files \
  --threads 1 --shard 0/2 --out data/training_pool_v1 > /dev/null &
"$omnipoint" synth --definition benchmarks/training_pool_v1.json --set train --core-files \
  --threads 1 --shard 1/2 --out data/training_pool_v1 > /dev/null
wait

train() {  # CONFIG RUN_DIR; a finished run (its final EMA weights written) is kept
  [[ -f $2/model_ema.safetensors ]] && return
  local resume=()
  [[ -e $2/checkpoints/latest ]] && resume=(--resume "$2")
  "$omnipoint" train --config "$1" --nproc 2 "${resume[@]}"
}
train "$config" runs/default_model
train examples/train/default_model/omnipoint_default_longer.json runs/default_model_longer
train examples/train/default_model/omnipoint_default_finetune.json runs/default_model_finetune
train examples/train/default_model/omnipoint_default_finetune2.json runs/default_model_finetune2
train examples/train/default_model/omnipoint_default_finetune3.json runs/default_model_finetune3
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model_finetune3/model_ema.safetensors \
  runs/default_model_finetune3/model_ema_f16.safetensors
train examples/train/default_model/omnipoint_default_finetune4.json runs/default_model_finetune4
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model_finetune4/model_ema.safetensors \
  runs/default_model_finetune4/model_ema_f16.safetensors
train examples/train/default_model/omnipoint_default_finetune5.json runs/default_model_finetune5
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model_finetune5/model_ema.safetensors \
  runs/default_model_finetune5/model_ema_f16.safetensors
train examples/train/default_model/omnipoint_default_finetune6.json runs/default_model_finetune6
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model_finetune6/model_ema.safetensors \
  models/omnipoint_default.safetensors
