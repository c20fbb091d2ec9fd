#!/usr/bin/env bash
# run_can_soak.sh - issue 5's ten-minute two-process closed loop over a real kernel CAN stack:
# boots the vcan guest (drivers/tests/run_vcan_tests.sh) with can_two_process_soak, which runs
# the lock-step reference, then `control --can vcan0` and `twin serve --plant fast --can vcan0`
# for 10 minutes of feeding, and judges the KPIs against the reference (in spec within 1
# point, throughput within 2 %), the books, the bus and candump's count of SYNC frames.
# About 12 minutes of wall time, one host core. Not part of the default tests.
#
#   hil_tests/run_can_soak.sh [build-dir] [out-dir]
#     build-dir  default build/release (the soak binary is built if missing)
#     out-dir    default <build-dir>/hil_tests/can_soak: console.log, lock_step.json,
#                control.json, twin.json and summary.txt
# Exit 0: the soak passed; 77: the guest cannot run here (see run_vcan_tests.sh); else failed.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(realpath "${1:-$root/build/release}")"
out="$(realpath -m "${2:-$build/hil_tests/can_soak}")"
binary="$build/hil_tests/can_two_process_soak"
cmake --build "$build" --target can_two_process_soak
mkdir -p "$out"

# The guest runs for the reference, ten minutes of feeding, the drain and the start-up: the
# recipe's default cap (300 s) is for the short tests.
echo "booting the vcan guest for the ten-minute soak ($(date -u +%H:%M:%S) UTC, about 11 min)"
status=0
FL_VCAN_WORK="$build/drivers/vcan_work" TIMEOUT=1200 \
  bash "$root/drivers/tests/run_vcan_tests.sh" "$binary" >"$out/console.log" 2>&1 || status=$?
# The guest prints each JSON on one console line behind its tag.
for tag_and_file in LOCK_STEP:lock_step CONTROL:control TWIN:twin; do
  tag="CAN_SOAK_${tag_and_file%%:*}: "
  sed -n "s/^.*$tag//p" "$out/console.log" >"$out/${tag_and_file#*:}.json"
done
{
  grep -a -E 'CAN_SOAK: |CAN_SMOKE: candump|\[  (PASSED|FAILED) |Failure|GUEST: (extra|done)' \
    "$out/console.log" || true
  echo "run_vcan_tests.sh exit status: $status"
} | tee "$out/summary.txt"
echo "console and KPIs in $out"
exit "$status"
