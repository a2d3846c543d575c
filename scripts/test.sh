#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite and the checks of
# docs/DEVELOPING.md: format, warnings as errors, CTest, clang-tidy on the files changed since
# the last clean full run, and the sanitizer lanes' CI parts.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --tests
bash scripts/check_format.sh
bash scripts/build.sh -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=ON -DOMNIPOINT_WERROR=ON
ctest --test-dir build --output-on-failure -j "$(nproc)"
bash scripts/clang_tidy.sh --changed
# AddressSanitizer + UBSan on the io, camera and geometry layers' tests; ThreadSanitizer on the
# tests of the multi-threaded parts.
bash scripts/sanitize.sh --ci
bash scripts/sanitize.sh --thread
