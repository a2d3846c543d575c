#!/usr/bin/env bash
# Installs the build into a temporary prefix, builds examples/consumer against the installed
# package (find_package(omnipoint)) and runs it on a tiny random model.
#   installed_consumer.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build=$1 source=$2 work=$3
rm -rf "$work/prefix" "$work/consumer"
cmake --install "$build" --prefix "$work/prefix" > /dev/null
launcher=()
if command -v ccache > /dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S "$source/examples/consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$work/prefix" "${launcher[@]}" > /dev/null
cmake --build "$work/consumer" -j 2 > /dev/null
"$work/prefix/bin/omnipoint" init-model --config "$source/examples/models/tiny_omnipoint.json" \
  --out "$work/tiny.safetensors" > /dev/null
"$work/consumer/omnipoint_consumer" "$work/tiny.safetensors"
