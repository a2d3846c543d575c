#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy's checks) over C++ files the build compiles. Needs a configured
# build/ (compile_commands.json; scripts/build.sh makes it). Exit status non-zero when any check
# fires; the full log is build/clang_tidy.log.
#   clang_tidy.sh [FILE-REGEX]   every compiled file matching, e.g. clang_tidy.sh 'src/omnipoint/io/'
#                                (default: the library, the tool, tests, benchmarks and tools)
#   clang_tidy.sh --changed      the files changed since the commit named in .ci/tidy-base (the
#                                last commit at which a full run found the whole tree clean),
#                                committed or not; a changed header is checked through the .cpp
#                                file of its name and through the changed files that include it.
#                                CI runs this (scripts/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
[[ -f build/compile_commands.json ]] || { echo "clang_tidy: run scripts/build.sh first" >&2; exit 2; }
patterns=("$PWD/${1:-(src|tests|bench|tools)/}")
if [[ "${1:-}" == "--changed" ]]; then
  base=$(tr -d '[:space:]' < .ci/tidy-base)
  if ! git cat-file -e "${base}^{commit}" 2>/dev/null; then
    echo "clang_tidy: .ci/tidy-base names ${base}, which is not a commit of this clone" >&2
    exit 2
  fi
  patterns=()
  while IFS= read -r file; do
    case "$file" in
      *.h) [[ -f "${file%.h}.cpp" ]] && patterns+=("^$PWD/${file%.h}\.cpp\$") ;;
      *.cpp) patterns+=("^$PWD/${file//./\\.}\$") ;;
    esac
  done < <(git diff --name-only --diff-filter=AMR "$base" -- src tests bench tools)
  # Files only the build lists (e.g. a .cpp with no compile command) are skipped by run-clang-tidy.
  if (( ${#patterns[@]} == 0 )); then
    echo "clang_tidy: no C++ file changed since ${base}"
    exit 0
  fi
fi
# run-clang-tidy (LLVM 14) always asks for colour: the codes are stripped from the log.
run-clang-tidy -quiet -p build -j "$(nproc)" "${patterns[@]}" 2>&1 |
  sed 's/\x1b\[[0-9;]*m//g' > build/clang_tidy.log || true
findings=$(grep -cE '^/.*: (warning|error): ' build/clang_tidy.log || true)
if (( findings )); then
  grep -E '^/.*: (warning|error): ' build/clang_tidy.log | sort -u >&2
  echo "clang_tidy: $findings finding(s); full log in build/clang_tidy.log" >&2
  exit 1
fi
echo "clang_tidy: clean ($(grep -c '^clang-tidy' build/clang_tidy.log || true) files)"
