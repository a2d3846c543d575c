#!/usr/bin/env bash
# Single-image latency: the whole `omnipoint forward` process against the network's own time,
# side by side. For each model config (ViT-S, ViT-L; random weights from `omnipoint init-model`)
# and precision, ROUNDS rounds alternate one tool process (wall and peak RSS by /usr/bin/time)
# and one bench_single_image process (load, first forward, warm forward), one `omnipoint
# predict` of examples/images/pinhole.png (wall and peak RSS) and one `omnipoint --version` (the
# cost of starting and ending a process of the tool: its libraries' loading and initialisers);
# prints the medians.
#   bench/single_image_latency.sh [ROUNDS] [CONFIGS...]   (defaults: 3, vits vitl)
# Run from the repository root after building; the models and input go to out/latency/.
set -euo pipefail
rounds=${1:-3}
[[ $# -gt 0 ]] && shift
configs=("$@")
[[ ${#configs[@]} -gt 0 ]] || configs=(vits vitl)
tool=build/src/cli/omnipoint bench=build/bench/bench_single_image dir=out/latency
mkdir -p "$dir"
# A 480x640 image (the benchmarks' size) as the (1, 3, H, W) float array `forward` reads.
[[ -f $dir/input.npy ]] || /usr/bin/python3 -c "
import numpy as np; np.random.seed(0)
np.save('$dir/input.npy', np.random.rand(1, 3, 480, 640).astype(np.float32))"
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
echo "uptime: $(uptime)"
printf '%-5s %-5s %10s %10s %10s %10s %8s %8s %10s %10s %10s %8s\n' config prec process_s network_s ratio \
  load_s read_s first_s peak_GB predict_s predict_GB start_s
for config in "${configs[@]}"; do
  model=$dir/omnipoint_$config.safetensors
  [[ -f $model ]] || "$tool" init-model --config "bench/models/omnipoint_$config.json" --out "$model" >/dev/null
  for precision in fp32 bf16; do
    : >"$dir/process" && : >"$dir/network" && : >"$dir/predict" && : >"$dir/start"
    for ((r = 0; r < rounds; r++)); do
      /usr/bin/time -f "%e %M" -o "$dir/time" "$tool" forward --model "$model" \
        --input "$dir/input.npy" --precision "$precision" --out "$dir/forward_out" >/dev/null
      cat "$dir/time" >>"$dir/process"
      # The tool runs passive OpenMP workers (src/cli/threads.cpp): the same here.
      OMP_WAIT_POLICY=passive "$bench" "$model" "$dir/input.npy" "$precision" 1 >>"$dir/network"
      /usr/bin/time -f "%e %M" -o "$dir/time" "$tool" predict examples/images/pinhole.png \
        --model "$model" --precision "$precision" --out "$dir/predict_out" >"$dir/predict.log" 2>&1
      cat "$dir/time" >>"$dir/predict"
      /usr/bin/time -f "%e" -o "$dir/time" "$tool" --version >/dev/null
      cat "$dir/time" >>"$dir/start"
    done
    process=$(cut -d' ' -f1 "$dir/process" | median)
    peak=$(cut -d' ' -f2 "$dir/process" | median)
    network=$(cut -d' ' -f3 "$dir/network" | median)
    load=$(cut -d' ' -f1 "$dir/network" | median)
    first=$(cut -d' ' -f2 "$dir/network" | median)
    read=$(cut -d' ' -f5 "$dir/network" | median)
    predict=$(cut -d' ' -f1 "$dir/predict" | median)
    predict_peak=$(cut -d' ' -f2 "$dir/predict" | median)
    start=$(median <"$dir/start")
    awk -v c="$config" -v p="$precision" -v s="$process" -v n="$network" -v l="$load" -v r="$read" -v f="$first" \
      -v m="$peak" -v ps="$predict" -v pm="$predict_peak" -v st="$start" \
      'BEGIN {printf "%-5s %-5s %10.2f %10.2f %10.2f %10.2f %8.2f %8.2f %10.2f %10.2f %10.2f %8.2f\n",
        c, p, s, n / 1000, s / (n / 1000), l / 1000, r / 1000, f / 1000, m / 1048576, ps,
        pm / 1048576, st}'
  done
done
echo "uptime: $(uptime)"
