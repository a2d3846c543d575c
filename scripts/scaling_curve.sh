#!/usr/bin/env bash
# Held-out scores against images seen: scores the EMA weights of every checkpoint of a training
# run on a benchmark (modes none and +K) and prints a table of points Rel per split.
#   scripts/scaling_curve.sh RUN_DIR DATA_DIR IMAGES_PER_STEP [OMNIPOINT_BINARY]
# IMAGES_PER_STEP: the global batch (batch_size × ranks); IMAGES_BEFORE (environment, default 0):
# the images seen before the run (a run initialised from another one). Checkpoints already
# scored (their RUN_DIR/scaling/step_N/summary.json exists) are kept. docs/TRAINING.md has the
# default model's.
set -euo pipefail
run=${1:?usage: scripts/scaling_curve.sh RUN_DIR DATA_DIR IMAGES_PER_STEP [OMNIPOINT_BINARY]}
data=${2:?DATA_DIR}
per_step=${3:?IMAGES_PER_STEP}
omnipoint=${4:-$(dirname "$0")/../build/src/cli/omnipoint}
mkdir -p "$run/scaling"

for checkpoint in "$run"/checkpoints/step_*/; do
  step=$(basename "$checkpoint")
  out=$run/scaling/$step
  [[ -f $out/summary.json ]] && continue
  "$omnipoint" eval --model "$checkpoint/ema.safetensors" --data "$data" --intrinsics \
    --label "$step" --out "$out" > /dev/null 2> "$run/scaling/$step.log" ||
    { echo "scaling_curve: eval of $step failed ($run/scaling/$step.log)" >&2; exit 1; }
done

/usr/bin/python3 - "$run/scaling" "$per_step" "${IMAGES_BEFORE:-0}" <<'EOF'
import json, pathlib, sys
root, per_step, before = pathlib.Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
splits = ["S.FoV", "L.FoV", "360°"]
print("| step | images seen | " + " | ".join(f"{s} points Rel (none / +K)" for s in splits) + " |")
print("|---|---|" + "---|" * len(splits))
for summary_path in sorted(root.glob("step_*/summary.json"),
                           key=lambda p: int(p.parent.name.split("_")[1])):
    summary = json.loads(summary_path.read_text())
    step = int(summary_path.parent.name.split("_")[1])
    cells = []
    for split in splits:
        modes = summary["scores"].get(split, {})
        rel = [modes.get(m, {}).get("entries", {}).get("points_scale_invariant", {}).get("rel")
               for m in ("none", "+K")]
        cells.append(" / ".join("–" if r is None else f"{100 * r:.1f}" for r in rel))
    print(f"| {step} | {before + step * per_step:,} | " + " | ".join(cells) + " |")
EOF
