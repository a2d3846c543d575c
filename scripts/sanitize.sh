#!/usr/bin/env bash
# The sanitizer lane: the library, the tool and the whole test suite built with
# AddressSanitizer + UBSan (any report fails the test that caused it) into build-asan/, then
# CTest. Usage: sanitize.sh [CTEST ARGS...]   e.g. sanitize.sh -R 'Camera|Ply'
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --tests
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DOMNIPOINT_SANITIZE=ON \
  -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=OFF > /dev/null
cmake --build build-asan -j "$(nproc)"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" "$@"
