#!/usr/bin/env bash
# tools/safetensors_to_f16.py, the way the bundled model is shipped: the F16 copy is about half
# the size, keeps the config, loads and predicts; a file that is not safetensors gives one
# line, a non-zero exit and no output file.
#   safetensors_to_f16.sh OMNIPOINT SOURCE_DIR
set -euo pipefail
omnipoint=$1
source_dir=$2
tool=$source_dir/tools/safetensors_to_f16.py
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$omnipoint" init-model --config "$source_dir/examples/models/tiny_omnipoint.json" --out "$dir/f32.safetensors"
/usr/bin/python3 "$tool" "$dir/f32.safetensors" "$dir/f16.safetensors"
f32=$(stat -c %s "$dir/f32.safetensors")
f16=$(stat -c %s "$dir/f16.safetensors")
(( f16 * 10 < f32 * 6 )) || fail "F16 copy is $f16 bytes for $f32"
"$omnipoint" predict "$source_dir/examples/images/pinhole.png" --model "$dir/f16.safetensors" --num-tokens 12 \
  --out "$dir/out" 2> "$dir/predict.log" || fail "predict with the F16 copy: $(cat "$dir/predict.log")"
[[ -f $dir/out/pinhole/points.ply ]] || fail "no points.ply from the F16 copy"

if /usr/bin/python3 "$tool" "$source_dir/examples/models/tiny_omnipoint.json" "$dir/bad.safetensors" 2> "$dir/err"; then
  fail "a JSON file was accepted"
fi
[[ $(wc -l < "$dir/err") -eq 1 ]] || fail "expected one error line, got: $(cat "$dir/err")"
grep -q "not a safetensors file" "$dir/err" || fail "unclear error: $(cat "$dir/err")"
[[ ! -e $dir/bad.safetensors ]] || fail "an output was left behind"
echo "safetensors_to_f16: ok ($f32 -> $f16 bytes)"
