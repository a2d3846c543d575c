#!/usr/bin/env bash
# The GPU check of docs/TRAINING.md ("On a GPU"), for a machine with an NVIDIA GPU, PyTorch
# (whose LibTorch the build uses), CMake, ninja and a compiler, but no OpenCV, no Debian
# packages and no network. Here first: scripts/gpu_pack.sh. There, in the checkout with .gpu/:
#   scripts/gpu_check.sh OUT_DIR [all|tests|train|cuda] [TRAIN_SECONDS]
# all (the default) is tests then train; cuda is the CUDA tests then train, building only
# the tool and those tests' executables: the shortest whole check, for a short lease.
# 1. Builds build/ (incrementally, going on past errors so one log lists them all) against
#    PyTorch's LibTorch, without OpenCV (no image files, so the training renders its scenes
#    on the machine's cores as it goes), without the viewer (no npm there) and without the
#    hub client (no libcurl headers there).
# 2. Runs the CUDA tests, then (all, tests) the suites that need no image files.
# 3. Trains examples/train/gpu/omnipoint_gpu.json, the bundled model's recipe with a wider
#    network and 32 images a step, for about TRAIN_SECONDS (default 240): a 20-step probe
#    measures the pace, and the stage-2 steps are set so that the whole schedule (its decay
#    and stage 3 included) fits.
# 4. Leaves in OUT_DIR the EMA weights as F16, the run's log.jsonl and curves.png, report.txt
#    (each step's status and seconds) and logs.tar.gz (build, tests, training, nvidia-smi).
# A failing step is reported and the steps that do not need it still run; the exit status is
# that of the first failure. Score the weights where image I/O is built (docs/TRAINING.md).
# Environment: PYTHON (python3: with PyTorch unless TORCH_PREFIX is given, and numpy),
# TORCH_PREFIX (default: PyTorch's cmake_prefix_path), GPU_CHECK_DEVICE (cuda;
# cpu rehearses the script on a machine without a GPU), GPU_CHECK_CMAKE_ARGS (extra, split
# on spaces), GPU_CHECK_DEADLINE (seconds from the start by which the script must be done:
# the training is shortened to fit, whatever the build took).
set -uo pipefail
cd "$(dirname "$0")/.."
usage="usage: scripts/gpu_check.sh OUT_DIR [all|tests|train|cuda] [TRAIN_SECONDS]"
out=${1:?$usage}
parts=${2:-all}
train_seconds=${3:-240}
deadline=${GPU_CHECK_DEADLINE:-0}
[[ $parts =~ ^(all|tests|train|cuda)$ && $train_seconds =~ ^[1-9][0-9]*$ &&
   $deadline =~ ^[0-9]+$ ]] ||
  { echo "gpu_check: $usage" >&2; exit 2; }
device=${GPU_CHECK_DEVICE:-cuda}
python=${PYTHON:-python3}
mkdir -p "$out"
out=$(cd "$out" && pwd)
logs=$(mktemp -d)
report=$out/report.txt
: > "$report"
status=0

step() {  # NAME COMMAND...: runs it with its output in logs/NAME.log, reports status and time
  local name=$1 start=$SECONDS rc=0
  shift
  "$@" > "$logs/$name.log" 2>&1 || rc=$?
  printf '%-8s %s  %4d s\n' "$name" "$([[ $rc == 0 ]] && echo ok || echo "FAILED ($rc)")" \
    $((SECONDS - start)) | tee -a "$report"
  (( rc == 0 )) || { (( status == 0 )) && status=$rc; tail -n 30 "$logs/$name.log" >&2; }
  return $rc
}

machine() {
  nvidia-smi || true
  nproc
  "$python" -c 'import torch; print("torch", torch.__version__, "cuda", torch.version.cuda)'
}

build() {
  local torch_prefix=${TORCH_PREFIX:-$("$python" -c 'import torch; print(torch.utils.cmake_prefix_path)')}
  # shellcheck disable=SC2086  # GPU_CHECK_CMAKE_ARGS is a list of arguments
  TORCH_CUDA_ARCH_LIST=${TORCH_CUDA_ARCH_LIST:-9.0} cmake -S . -B build -G Ninja \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$torch_prefix;$PWD/.gpu/root/usr" \
    -DOMNIPOINT_WITH_OPENCV=OFF -DOMNIPOINT_WITH_VIEWER=OFF -DOMNIPOINT_WITH_HUB=OFF \
    -DOMNIPOINT_BUILD_TESTS=ON \
    -DOMNIPOINT_BUILD_BENCH=OFF \
    ${GPU_CHECK_CMAKE_ARGS:-} || return
  local targets=()
  case $parts in
    train) targets=(--target omnipoint_cli) ;;
    cuda) targets=(--target omnipoint_cli alignment_tests train_tests) ;;
  esac
  cmake --build build -j "$(nproc)" "${targets[@]}" -- -k 0
}

cuda_tests() {
  ctest --test-dir build --output-on-failure -R 'Cuda' --no-tests=error
}

# The suites that need no image file (without OpenCV the others cannot read their inputs):
# the lower layers (io, camera, geometry) and the network, loss, training and metric tests.
other_tests() {
  local on_tensors='^(OmniPointModel|OmniPointInit|DinoV2|MoGe2|MoGe2Config|MoGe2Fixture|StateDict'
  on_tensors+='|Conditioning|Precision|Losses|Trainer|TrainConfig|BatchSource|Teacher|Alignment'
  on_tensors+='|PerspectiveToAny|AnyToPerspective|Metrics|ScaleFit|PointsFit|AffineFit|Infer)\.'
  ctest --test-dir build --output-on-failure -j "$(nproc)" --timeout 300 -L lower-layers &&
    ctest --test-dir build --output-on-failure -j "$(nproc)" --timeout 300 -R "$on_tensors"
}

# The run's config: the committed one with the measured number of stage-2 steps (and, for a
# rehearsal, the CPU), as a config that extends it; $1: the images per second of the probe, or 0
# for the probe itself.
write_config() {
  "$python" - "$1" "$train_seconds" "$device" "$(nproc)" "$2" > "$3" <<'EOF'
import json, os, sys
images_per_s, seconds, device, cores, output_dir = (
    float(sys.argv[1]), float(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5])
committed = "examples/train/gpu/omnipoint_gpu.json"
# The stages and the batch are the GPU run's own keys (it extends the default recipe).
config = json.load(open(committed))
stage2, stage3 = config["stages"]
batch = 4 if device == "cpu" else config["data"]["batch_size"]  # a rehearsal: small steps
run = {"extends": os.path.abspath(committed), "device": device, "threads": cores,
       "output_dir": output_dir, "data": {"batch_size": batch}}
if images_per_s > 0:
    # 0.85: the in-run evaluations and checkpoints take their share of the time.
    steps = int(0.85 * seconds * images_per_s / batch) - stage3["steps"]
    stage2["steps"] = max(steps, 20)
    stage2["warmup_steps"] = min(stage2["warmup_steps"], stage2["steps"] // 5)
    stage3["steps"] = min(stage3["steps"], stage2["steps"] // 5)
    run["stages"] = [stage2, stage3]
    run["eval_every"] = max(stage2["steps"] // 4, 1)
    run["checkpoint_every"] = max(stage2["steps"] // 8, 1)
json.dump(run, sys.stdout, indent=2)
EOF
}

probe() {
  rm -rf runs/gpu_probe
  write_config 0 runs/gpu_probe "$logs/probe.json" &&
    build/src/cli/omnipoint train --config "$logs/probe.json" --stop-after 20 &&
    "$python" - "$logs/probe.json" runs/gpu_probe/log.jsonl > "$logs/images_per_s" <<'EOF'
import json, statistics, sys
batch = json.load(open(sys.argv[1]))["data"]["batch_size"]
# The median step of the last 10 (past the warm-up): data, forward, loss, backward, optimiser.
records = [json.loads(line) for line in open(sys.argv[2])][-10:]
step_seconds = statistics.median(
    sum(seconds for part, seconds in r["seconds"].items() if "." not in part) for r in records)
print(batch / step_seconds)
EOF
}

train() {
  local pace
  pace=$(cat "$logs/images_per_s" 2> /dev/null || echo 0)
  [[ $pace != 0 ]] || { echo "no pace from the probe"; return 1; }
  echo "probe: $pace images/s"
  local kill_after=$((train_seconds + 120))
  if ((deadline > 0)); then  # what is left, less the bring-back and the run's start and end
    local left=$((deadline - SECONDS - 60))
    ((left >= 30)) || { echo "no time left to train ($left s)"; return 1; }
    ((left < train_seconds)) && train_seconds=$left && echo "training for $left s (deadline)"
    kill_after=$((deadline - SECONDS - 30))
  fi
  rm -rf runs/gpu_model
  write_config "$pace" runs/gpu_model "$logs/run.json" &&
    cp "$logs/run.json" "$out/" &&
    timeout --signal=KILL "$kill_after" \
      build/src/cli/omnipoint train --config "$logs/run.json"
}

bring_back() {
  local weights=runs/gpu_model/model_ema.safetensors
  if [[ ! -f $weights ]]; then  # stopped by the time limit: its last checkpoint
    [[ -f runs/gpu_model/checkpoints/latest ]] || { echo "the run left no checkpoint"; return 1; }
    weights=runs/gpu_model/checkpoints/$(cat runs/gpu_model/checkpoints/latest)/ema.safetensors
    echo "the run did not finish: bringing back $weights"
  fi
  "$python" tools/safetensors_to_f16.py "$weights" "$out/omnipoint_gpu_f16.safetensors" &&
    cp runs/gpu_model/log.jsonl "$out/" &&
    { cp runs/gpu_model/curves.png "$out/" 2> /dev/null || true; }
}

step machine machine
if step build build; then
  if [[ $parts != train ]]; then
    step cuda_tests cuda_tests
    [[ $parts == cuda ]] || step tests other_tests
  fi
  if [[ $parts != tests ]]; then
    step probe probe && step train train
    [[ -d runs/gpu_model ]] && step bring_back bring_back
  fi
fi
tar -czf "$out/logs.tar.gz" -C "$logs" .
rm -rf "$logs"
exit $status
