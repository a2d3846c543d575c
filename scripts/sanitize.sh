#!/usr/bin/env bash
# The sanitizer lane: the library, the tool and the test suite built with AddressSanitizer +
# UBSan (any report fails the test that caused it) into build-asan/, then CTest.
#   sanitize.sh [CTEST ARGS...]   everything, e.g. sanitize.sh -R 'Camera|Ply' for part of it
#   sanitize.sh --ci              the stated subset CI runs (README "Checks"): the test
#                                 executables of the io, camera and geometry layers, built
#                                 from those layers alone (label lower-layers)
set -euo pipefail
cd "$(dirname "$0")/.."
targets=(all)
ctest_args=("$@")
if [[ "${1:-}" == "--ci" ]]; then
  targets=(lower_layer_tests)
  ctest_args=(-L lower-layers "${@:2}")
fi
bash scripts/install_deps.sh --tests
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DOMNIPOINT_SANITIZE=ON \
  -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=OFF > /dev/null
cmake --build build-asan -j "$(nproc)" --target "${targets[@]}"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" "${ctest_args[@]}"
