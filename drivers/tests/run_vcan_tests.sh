#!/usr/bin/env bash
# run_vcan_tests.sh - runs the SocketCAN/CANopen test binary on a real Linux CAN stack (vcan0)
# inside qemu, through the project's verified recipe ../shared/recipes/can_vm/run.sh (the
# host kernel has no CAN). The recipe boots Debian's stock kernel, loads can, can-raw,
# can-dev, vcan, creates vcan0 and runs every extra binary given to it (their shared
# libraries copied into the initramfs). candump (can-utils) goes along as an independent
# peer: the test binary starts it from /opt/candump (with no arguments the recipe's own run
# of it just prints its usage and exits 0).
#
#   drivers/tests/run_vcan_tests.sh [path/to/drivers_vcan_tests | path/to/can_two_process_smoke]
#   FL_VCAN_WORK=dir   scratch dir for the kernel cache and the initramfs
#                      (default: build/h-drivers/drivers/vcan_work; never inside ../shared,
#                      which is read-only in CI)
#   FL_REQUIRE_VCAN=1  a missing qemu, busybox-static, recipe or candump fails (exit 1) instead
#                      of skipping: scripts/test.sh sets it, so CI cannot pass without the
#                      real kernel stack and its independent peer
# Exit 0: passed; 77: skipped (qemu-system-x86 or busybox-static not installed); else failed.
set -euo pipefail
HERE="$(cd "$(dirname "$0")" && pwd)"
ROOT="$(cd "$HERE/../.." && pwd)"
RECIPE="$ROOT/../shared/recipes/can_vm/run.sh"
BINARY="${1:-$ROOT/build/h-drivers/drivers/drivers_vcan_tests}"

# Without the real stack the tests cannot run: skipped for a developer, failed where required.
missing() {
  if [ "${FL_REQUIRE_VCAN:-0}" = 1 ]; then
    echo "FAIL (FL_REQUIRE_VCAN=1): $1"
    exit 1
  fi
  echo "SKIP: $1"
  exit 77
}
if ! command -v qemu-system-x86_64 >/dev/null || ! dpkg -s busybox-static >/dev/null 2>&1; then
  missing "the vcan tests need qemu-system-x86 and busybox-static (apt-get install them)"
fi
if [ ! -x "$RECIPE" ] && [ ! -f "$RECIPE" ]; then
  missing "recipe $RECIPE not found"
fi
if ! command -v candump >/dev/null; then
  [ "${FL_REQUIRE_VCAN:-0}" = 1 ] && missing "candump (can-utils) not installed: no independent peer"
fi
if [ ! -x "$BINARY" ]; then
  echo "building $BINARY"
  cmake --build "$ROOT/build/h-drivers" --target drivers_vcan_tests
fi

export WORK="${FL_VCAN_WORK:-$ROOT/build/h-drivers/drivers/vcan_work}"
mkdir -p "$WORK"
extra=("$BINARY")
if command -v candump >/dev/null; then
  extra=("$(command -v candump)" "$BINARY")
else
  echo "NOTE: candump (can-utils) not installed: frames are not cross-checked by a peer"
fi
# The recipe prints the guest console; its exit status is ours.
bash "$RECIPE" "${extra[@]}"
