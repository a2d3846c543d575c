#!/usr/bin/env bash
# The sanitizer lanes (docs/DEVELOPING.md, "Sanitizers"):
#   sanitize.sh [CTEST ARGS...]   AddressSanitizer + UBSan: the library, the tool and the test
#                                 suite built into build-asan/, then CTest (any report fails the
#                                 test that caused it), e.g. sanitize.sh -R 'Camera|Ply'
#   sanitize.sh --ci              the AddressSanitizer subset CI runs: the test executables of
#                                 the io, camera and geometry layers, built from those layers
#                                 alone (label lower-layers)
#   sanitize.sh --thread          ThreadSanitizer: the tests of the multi-threaded parts (label
#                                 threads) built with clang and LLVM's OpenMP into build-tsan/
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --tests
if [[ "${1:-}" == "--thread" ]]; then
  cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ \
    -DOMNIPOINT_TSAN=ON -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=OFF \
    -DOMNIPOINT_WITH_VIEWER=OFF > /dev/null
  cmake --build build-tsan -j "$(nproc)" --target thread_tests
  ctest --test-dir build-tsan --output-on-failure -j "$(nproc)" -L threads "${@:2}"
  exit
fi
targets=(all)
ctest_args=("$@")
if [[ "${1:-}" == "--ci" ]]; then
  targets=(lower_layer_tests)
  ctest_args=(-L lower-layers "${@:2}")
fi
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DOMNIPOINT_SANITIZE=ON \
  -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=OFF > /dev/null
cmake --build build-asan -j "$(nproc)" --target "${targets[@]}"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:detect_stack_use_after_return=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --test-dir build-asan --output-on-failure -j "$(nproc)" "${ctest_args[@]}"
