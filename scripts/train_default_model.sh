#!/usr/bin/env bash
# How the bundled model (models/omnipoint_default.safetensors) is made; docs/TRAINING.md,
# "The bundled model". About an hour on a 2-core CPU.
#   scripts/train_default_model.sh [OMNIPOINT_BINARY]
# Stage 1 (perspective pretraining) writes runs/default_model/perspective/; its EMA weights
# initialise stages 2 and 3 (camera-universal fine-tuning with P2A, A2P and the conditions,
# then the mask head) and are A2P's teacher. The final EMA weights are shipped as F16.
set -euo pipefail
cd "$(dirname "$0")/.."
omnipoint=${1:-build/src/cli/omnipoint}
"$omnipoint" train --config examples/train/default_model/perspective.json
"$omnipoint" train --config examples/train/default_model/universal.json
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model/universal/model_ema.safetensors \
  models/omnipoint_default.safetensors
