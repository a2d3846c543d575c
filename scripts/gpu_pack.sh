#!/usr/bin/env bash
# Packs what scripts/gpu_check.sh needs on a GPU machine that has PyTorch, CMake, ninja and a
# compiler but no Debian packages and no network: the files of the small build dependencies
# (nlohmann-json, CLI11, GoogleTest, liblzf), as Debian installed them here, under
# .gpu/root/usr (git ignores .gpu/). Run it here, then carry .gpu to the GPU machine
# (docs/TRAINING.md, "On a GPU").
#   scripts/gpu_pack.sh
set -euo pipefail
cd "$(dirname "$0")/.."
packages=(nlohmann-json3-dev libcli11-dev libgtest-dev liblzf-dev liblzf1)
for package in "${packages[@]}"; do
  dpkg -s "$package" > /dev/null 2>&1 ||
    { echo "gpu_pack: $package is not installed (bash scripts/install_deps.sh --tests)" >&2; exit 1; }
done
rm -rf .gpu/root
mkdir -p .gpu/root
# Files and links (liblzf.so -> liblzf.so.1) keep their paths below .gpu/root.
for package in "${packages[@]}"; do
  dpkg -L "$package" | while read -r file; do
    if [[ ( -f $file || -L $file ) && $file != /usr/share/doc/* ]]; then echo "${file#/}"; fi
  done
done | tar -cf - -C / --no-recursion -T - | tar -xf - -C .gpu/root
echo "gpu_pack: $(du -sh .gpu/root | cut -f1) in .gpu/root ($(find .gpu/root -type f | wc -l) files)"
