#!/usr/bin/env bash
# How the bundled model (models/omnipoint_default.safetensors) is made; docs/TRAINING.md,
# "The bundled model". About 75 minutes on a 2-core CPU.
#   scripts/train_default_model.sh [OMNIPOINT_BINARY]
# Stage 1 (perspective pretraining) writes runs/default_model/perspective/; its EMA weights
# initialise stages 2 and 3 (camera-universal fine-tuning with P2A, A2P and the conditions,
# then the mask head) and are A2P's teacher. A second, shorter pass of stages 2 and 3 with the
# conditions at probability 0.5 (refine.json) follows; its EMA weights are shipped as F16.
set -euo pipefail
cd "$(dirname "$0")/.."
omnipoint=${1:-build/src/cli/omnipoint}
"$omnipoint" train --config examples/train/default_model/perspective.json
"$omnipoint" train --config examples/train/default_model/universal.json
"$omnipoint" train --config examples/train/default_model/refine.json
/usr/bin/python3 tools/safetensors_to_f16.py runs/default_model/refine/model_ema.safetensors \
  models/omnipoint_default.safetensors
