#!/usr/bin/env bash
# Writing one prediction with every output, direct against cached writes, side by side:
#   bench/predict_writing.sh IMAGE [ROUNDS] [OMNIPOINT]   (default 3 rounds, build/src/cli/omnipoint)
# Each round runs `predict IMAGE --outputs all` with direct writes (the default), then with
# --cached-writes, each into a fresh folder after a pause: on a VM that returns freed memory to
# its host, the page cache's first write into a returned page costs a host fault, so every run
# starts from the same state. Prints predict's own stage times and the whole process's wall time.
# (docs/PERFORMANCE.md, "Direct writes".)
set -euo pipefail
[[ $# -ge 1 ]] || { sed -n 2,3p "$0" >&2; exit 2; }
image=$1
rounds=${2:-3}
omnipoint=${3:-build/src/cli/omnipoint}
pause=${PAUSE_S:-25}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
uptime
for round in $(seq "$rounds"); do
  for mode in direct cached; do
    flag=()
    [[ $mode == cached ]] && flag=(--cached-writes)
    rm -rf "$out/prediction"
    sleep "$pause"
    start=$(date +%s%N)
    line=$("$omnipoint" predict "$image" --outputs all --out "$out/prediction" "${flag[@]}" 2>&1 |
      grep -o 'decode.*writing [0-9]* ms')
    echo "round $round $mode: $line, whole process $((($(date +%s%N) - start) / 1000000)) ms"
  done
done
rm -rf "$out/prediction"
uptime
