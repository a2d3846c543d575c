#!/usr/bin/env bash
# Installs the build into a temporary prefix, builds examples/consumer against the installed
# package (find_package(omnipoint)) and runs it on a folder of rendered images with a tiny
# random model: every image must get its output folder, at the size the consumer asked for.
#   installed_consumer.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build=$1 source=$2 work=$3
rm -rf "$work/prefix" "$work/consumer" "$work/images" "$work/out"
cmake --install "$build" --prefix "$work/prefix" > /dev/null
launcher=()
if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S "$source/examples/consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$work/prefix" "${launcher[@]}" > /dev/null
cmake --build "$work/consumer" -j 2 > /dev/null
omnipoint=$work/prefix/bin/omnipoint
"$omnipoint" init-model --config "$source/examples/models/tiny_omnipoint.json" \
  --out "$work/tiny.safetensors" > /dev/null
# Two 48x36 pictures, as IMAGES/000000/image.png and IMAGES/000001/image.png.
"$omnipoint" synth --camera "PINHOLE 48 36 40 40 24 18" --count 2 --core-files --no-shadows \
  --no-ao --out "$work/images" > /dev/null
find "$work/images" -type f ! -name image.png -delete  # the sample's maps: not pictures
"$work/consumer/omnipoint_consumer" "$work/tiny.safetensors" "$work/images" "$work/out"
for sample in 000000 000001; do
  folder=$work/out/$sample/image
  for file in points.ply camera.json mask.png; do
    [[ -f $folder/$file ]] || { echo "missing $folder/$file" >&2; exit 1; }
  done
  # max_size 32: the outputs are 32x24 (a PNG's width and height are bytes 16-23).
  size=$(od -An -tu1 -j16 -N8 "$folder/mask.png" | tr -s ' ')
  [[ $size == " 0 0 0 32 0 0 0 24" ]] || { echo "$folder/mask.png: not 32x24 ($size)" >&2; exit 1; }
done
