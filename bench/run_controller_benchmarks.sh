#!/usr/bin/env bash
# Controller figures for docs/benchmarks.md, in one run on one machine:
#   1. logic compute time per scan with 20+ tracked fillets (Google Benchmark),
#   2. lock-step closed-loop speed against the fast plant (Google Benchmark and a 10-minute
#      linectl run timed as a whole),
#   3. wake-up jitter of the 10 ms runtime beside cyclictest (needs root; skip with JITTER=0).
# Usage: bench/run_controller_benchmarks.sh [-d JITTER_SECONDS]   (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
jitter_s=60
while getopts "d:" option; do
  case "${option}" in
    d) jitter_s="${OPTARG}" ;;
    *) sed -n '2,9p' "$0"; exit 2 ;;
  esac
done

bash scripts/build.sh release >/dev/null
echo "# $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"

echo "## bench_controller"
build/release/bench/bench_controller --benchmark_counters_tabular=true 2>/dev/null

echo "## linectl run --plant fast --duration 10m --seed 1 (timed as a whole)"
start=$(date +%s.%N)
build/release/apps/linectl/linectl run --plant fast --duration 10m --seed 1 --quiet --log-level error
end=$(date +%s.%N)
awk -v s="$start" -v e="$end" 'BEGIN { printf "whole command: %.2f s wall\n", e - s }'

if [[ "${JITTER:-1}" != 0 ]]; then
  echo "## jitter, ${jitter_s} s per mode"
  bench/jitter/compare_cyclictest.sh -d "${jitter_s}" -b build/release/bench/jitter/fl_jitter
fi
