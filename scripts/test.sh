#!/usr/bin/env bash
# The project's full check, as CI runs it:
#   1. formatting of every C++ file (clang-format, the repo's .clang-format),
#   2. release build with warnings as errors, all tests (unit, closed loop, HIL on loopback),
#      then its Debian package installed and run on a clean Debian 12 root (deploy_test.sh),
#   3. address + undefined sanitizer build, the unit tests again,
#   4. the libFuzzer targets (fuzz/), each for 30 s on its seed corpus.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== format check"
mapfile -t sources < <(git ls-files '*.cpp' '*.hpp')
clang-format --dry-run --Werror "${sources[@]}"

echo "== release build and tests"
bash scripts/build.sh release
# The vcan tests (qemu guest with a real kernel CAN stack) must run here, not skip.
FL_REQUIRE_VCAN=1 ctest --preset release

echo "== deployment: the Debian package on a clean Debian 12 root (docs/deployment.md)"
if [[ $(id -u) -eq 0 ]]; then
  bash scripts/deploy_test.sh build/release
else
  echo "SKIPPED: scripts/deploy_test.sh needs root (debootstrap, chroot)"
fi

echo "== sanitizer build (address, undefined) and unit tests"
bash scripts/build.sh asan
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --preset asan

echo "== fuzzing (libFuzzer, clang; each target 30 s on its seed corpus, docs/fuzzing.md)"
bash scripts/fuzz.sh 30
