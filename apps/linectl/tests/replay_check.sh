#!/usr/bin/env bash
# CTest driver for `linectl replay` (apps/linectl/CMakeLists.txt): one check per call.
#   replay_check.sh MODE LINECTL RECORDING GOLDEN WORKDIR
# MODE: match      the recording replays exactly as its golden result (exit 0)
#       perturbed  a perturbed estimator threshold is reported as differences (exit 1)
#       truncated  a truncated copy is refused with an error naming the file (exit 2)
#       corrupted  a copy with one damaged byte inside a chunk is refused (exit 2)
set -u
mode=$1 linectl=$2 recording=$3 golden=$4 work=$5
mkdir -p "$work"

fail() { echo "FAIL ($mode): $*"; exit 1; }
# expect RC PATTERN COMMAND...: the command exits RC and prints PATTERN.
expect() {
  local expected=$1 pattern=$2
  shift 2
  local output rc
  output=$("$@" 2>&1)
  rc=$?
  echo "$output" | tail -n 20
  [ "$rc" -eq "$expected" ] || fail "exit $rc, expected $expected: $*"
  grep -q -- "$pattern" <<<"$output" || fail "output lacks '$pattern'"
  echo "ok ($mode)"
}

case $mode in
  match)
    expect 0 "matches" "$linectl" replay "$recording" --golden "$golden" ;;
  perturbed)
    # Every fillet of table 3.1 is larger than 6000 mm^2: all become "not singulated", which
    # changes the estimates and the controller's decisions (rejects instead of flips).
    expect 1 "differences against" "$linectl" replay "$recording" --golden "$golden" \
      --set max_single_area_mm2=6000 --max-diffs 5 ;;
  truncated)
    size=$(stat -c %s "$recording")
    head -c $((size / 2)) "$recording" >"$work/truncated.mcap"
    expect 2 "truncated.mcap: not a readable MCAP recording" "$linectl" replay \
      "$work/truncated.mcap" --golden "$golden" ;;
  corrupted)
    cp "$recording" "$work/corrupted.mcap"
    chmod u+w "$work/corrupted.mcap"
    # A third into the file lies inside a compressed chunk of frames: its CRC no longer matches.
    size=$(stat -c %s "$recording")
    printf '\xa5' | dd of="$work/corrupted.mcap" bs=1 seek=$((size / 3)) conv=notrunc status=none
    expect 2 "corrupted.mcap" "$linectl" replay "$work/corrupted.mcap" --golden "$golden" ;;
  *)
    fail "unknown mode" ;;
esac
