#!/usr/bin/env bash
# Estimate latency side by side with Cyclone's own ddsperf, on the shipped loopback
# configuration and one host:
#   1. dds_estimate_latency: one-way publish->take of CameraEstimates (full frame of 8
#      estimates) from a child process, 2 kHz, and the same within one process;
#   2. ddsperf ping/pong between two processes with a payload of the serialised frame's size
#      at the same rate: round trips (one way is about half), an independent peer built from
#      Cyclone's own tools.
#
#   drivers/dds/bench/compare_ddsperf.sh [BUILD_DIR=build/h-dds] [SAMPLES=10000]
set -euo pipefail
root=$(cd "$(dirname "$0")/../../.." && pwd)
build=${1:-$root/build/h-dds}
samples=${2:-10000}
export CYCLONEDDS_URI=file://$root/config/dds/cyclonedds-loopback.xml
# 2 kHz: twenty samples per 10 ms scan, far above the line's 5 cameras at 25-40 ms, and
# slow enough that two shared cores do not queue.
interval_us=500
rate_hz=$((1000000 / interval_us))
seconds=$((samples / rate_hz + 3))
# CDR size of a full CameraEstimates: 1 + 7 pad + 8 + 4 + 1 + 3 pad + 8 * 28 = 256 bytes.
payload_bytes=256
domain=78  # away from the tests' domains (11..42) and the benchmark's (77)

echo "== dds_estimate_latency: $samples samples, one way"
"$build/drivers/dds/dds_estimate_latency" "$samples" "$interval_us"

echo "== ddsperf ping/pong: ${rate_hz} Hz, ${payload_bytes} B, ${seconds} s, round trip"
ddsperf -i "$domain" -D "$seconds" pong waitset >/dev/null 2>&1 &
pong=$!
trap 'kill "$pong" 2>/dev/null || true' EXIT
sleep 0.5
# ddsperf prints the round-trip statistics of each second (mean, min, 50/90/99 %, max).
ddsperf -i "$domain" -D "$((seconds - 1))" ping "${rate_hz}Hz" size "$payload_bytes" waitset 2>&1 |
  grep -E "size $payload_bytes"
wait "$pong" 2>/dev/null || true
