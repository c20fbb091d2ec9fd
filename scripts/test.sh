#!/usr/bin/env bash
# The project's full check, as CI runs it:
#   1. formatting of every C++ file (clang-format, the repo's .clang-format),
#   2. release build with warnings as errors, all tests (unit, closed loop, HIL on loopback),
#   3. address + undefined sanitizer build, the unit tests again.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== format check"
mapfile -t sources < <(git ls-files '*.cpp' '*.hpp')
clang-format --dry-run --Werror "${sources[@]}"

echo "== release build and tests"
bash scripts/build.sh release
ctest --preset release

echo "== sanitizer build (address, undefined) and unit tests"
bash scripts/build.sh asan
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --preset asan
