#!/usr/bin/env bash
# Wake-up latency of the scan runtime (fl_jitter) next to cyclictest (rt-tests), at the same
# period and duration, back to back on the same machine: SCHED_FIFO 80 and SCHED_OTHER for
# each. Both lock memory and hold /dev/cpu_dma_latency at 0 (cyclictest's default), so the
# only difference is the code around the sleep. Writes a markdown table.
#
# Usage: bench/jitter/compare_cyclictest.sh [-d SECONDS] [-i PERIOD_US] [-a CPU]
#                                           [-b PATH_TO_FL_JITTER] [-o OUTPUT.md]
# Needs root (SCHED_FIFO, mlockall, /dev/cpu_dma_latency). Percentiles are nearest-rank over
# 1 us bins for both tools (cyclictest's histogram, fl_jitter's CycleStats), in us.
set -euo pipefail

duration_s=60
period_us=10000
cpu=""
fl_jitter="build/release/bench/jitter/fl_jitter"
output=""
while getopts "d:i:a:b:o:h" option; do
  case "${option}" in
    d) duration_s="${OPTARG}" ;;
    i) period_us="${OPTARG}" ;;
    a) cpu="${OPTARG}" ;;
    b) fl_jitter="${OPTARG}" ;;
    o) output="${OPTARG}" ;;
    *) sed -n '2,12p' "$0"; exit 2 ;;
  esac
done

command -v cyclictest >/dev/null || { echo "cyclictest not found (apt install rt-tests)" >&2; exit 1; }
[[ -x "${fl_jitter}" ]] || { echo "${fl_jitter} not built (cmake --build ... --target fl_jitter)" >&2; exit 1; }

histogram_us=100000  # wide enough that SCHED_OTHER spikes stay inside the histogram
cyclictest_common=(-m -t1 -i "${period_us}" -D "${duration_s}" -h "${histogram_us}" -q)
fl_jitter_common=(-i "${period_us}" -D "${duration_s}" -m --cpu-dma-latency-us 0)
if [[ -n "${cpu}" ]]; then
  cyclictest_common+=(-a "${cpu}")
  fl_jitter_common+=(-a "${cpu}")
fi

rows=()

load_1min() { cut -d' ' -f1 /proc/loadavg; }

# cyclictest -h prints "<us> <count>" rows and "# Min/Avg/Max Latencies:" lines; the
# percentiles use the same nearest rank as CycleStats, the max when the rank overflows.
summarise_cyclictest() {
  awk '
    /^[0-9]+[ \t]+[0-9]+/ { bucket[n] = $1 + 0; count[n] = $2 + 0; total += $2; n++ }
    /^# Min Latencies:/ { min = $4 + 0 }
    /^# Avg Latencies:/ { avg = $4 + 0 }
    /^# Max Latencies:/ { max = $4 + 0 }
    /^# Histogram Overflows:/ { overflows = $4 + 0 }
    function percentile(q,   rank, seen, i) {
      rank = q * (total + overflows); if (rank > int(rank) + 1e-9) rank = int(rank) + 1; else rank = int(rank)
      if (rank < 1) rank = 1
      seen = 0
      for (i = 0; i < n; i++) { seen += count[i]; if (seen >= rank) return bucket[i] }
      return max
    }
    END {
      printf "%d|%d|%d|%d|%d|%d|%d\n", total + overflows, min, avg, percentile(0.5),
             percentile(0.99), percentile(0.999), max
    }'
}

summarise_fl_jitter() {
  awk '/^RESULT/ {
    for (i = 2; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
    printf "%d|%.1f|%.1f|%.0f|%.0f|%.0f|%.1f\n", v["samples"], v["min_us"], v["avg_us"],
           v["p50_us"], v["p99_us"], v["p999_us"], v["max_us"]
  }'
}

run() {
  local label="$1" policy="$2" kind="$3"
  shift 3
  local load
  load="$(load_1min)"
  echo ">> ${label} (${policy}): $*" >&2
  local summary
  if [[ "${kind}" == cyclictest ]]; then
    summary="$("$@" 2>/dev/null | summarise_cyclictest)"
  else
    summary="$("$@" 2>/dev/null | summarise_fl_jitter)"
  fi
  IFS='|' read -r samples min avg p50 p99 p999 max <<<"${summary}"
  rows+=("| ${label} | ${policy} | ${samples} | ${min} | ${avg} | ${p50} | ${p99} | ${p999} | ${max} | ${load} |")
}

run cyclictest "SCHED_FIFO 80" cyclictest cyclictest "${cyclictest_common[@]}" -p 80
run cyclictest "SCHED_OTHER" cyclictest cyclictest "${cyclictest_common[@]}" --policy=other
run fl_jitter "SCHED_FIFO 80" fl_jitter "${fl_jitter}" "${fl_jitter_common[@]}" -p 80
run fl_jitter "SCHED_OTHER" fl_jitter "${fl_jitter}" "${fl_jitter_common[@]}" -p 0

{
  echo "Wake-up latency, period ${period_us} us, ${duration_s} s per run, back to back;"
  echo "$(nproc) CPUs, $(uname -sr), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'),"
  echo "$(date -u '+%Y-%m-%d %H:%M UTC')${cpu:+, pinned to CPU ${cpu}}. All values in us."
  echo
  echo "| Tool | Policy | Samples | Min | Avg | p50 | p99 | p99.9 | Max | Load (1 min) at start |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
  printf '%s\n' "${rows[@]}"
} | if [[ -n "${output}" ]]; then tee "${output}"; else cat; fi
