#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy's checks) over every C++ file the build compiles: the library,
# the tool, tests and benchmarks. Needs a configured build/ (compile_commands.json; scripts/
# build.sh makes it). Usage: clang_tidy.sh [FILE-REGEX]   e.g. clang_tidy.sh 'src/omnipoint/io/'
# Exit status non-zero when any check fires.
set -euo pipefail
cd "$(dirname "$0")/.."
[[ -f build/compile_commands.json ]] || { echo "clang_tidy: run scripts/build.sh first" >&2; exit 2; }
# run-clang-tidy (LLVM 14) always asks for colour: the codes are stripped from the log.
run-clang-tidy -quiet -p build -j "$(nproc)" "$PWD/${1:-(src|tests|bench|tools)/}" 2>&1 |
  sed 's/\x1b\[[0-9;]*m//g' > build/clang_tidy.log || true
findings=$(grep -cE '^/.*: (warning|error): ' build/clang_tidy.log || true)
if (( findings )); then
  grep -E '^/.*: (warning|error): ' build/clang_tidy.log | sort -u >&2
  echo "clang_tidy: $findings finding(s); full log in build/clang_tidy.log" >&2
  exit 1
fi
echo "clang_tidy: clean ($(grep -c '^clang-tidy' build/clang_tidy.log || true) files)"
