#!/usr/bin/env bash
# Builds the libFuzzer targets (preset fuzz: clang, address + undefined sanitizers) and runs
# each for a bounded time on a copy of its seed corpus (fuzz/corpus/<target>, never written
# here). Exits non-zero on any crash, leak, timeout or out-of-memory, naming the target and
# the reproducer under build/fuzz/artifacts/. See docs/fuzzing.md.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET]     default 30
#   FL_FUZZ_JOBS=N                            targets run side by side (default: nproc)
#   FL_FUZZ_TARGETS="fuzz_cdr fuzz_can_frames"  only these
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
jobs="${FL_FUZZ_JOBS:-$(nproc)}"
build=build/fuzz
artifacts="$build/artifacts"
work="$build/fuzz_work"  # corpus copies and logs of this run

if [[ -n "${FL_FUZZ_TARGETS:-}" ]]; then
  read -r -a targets <<<"$FL_FUZZ_TARGETS"
else
  targets=()
  for source in fuzz/fuzz_*.cpp; do
    targets+=("$(basename "$source" .cpp)")
  done
fi

started=$SECONDS
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$(nproc)"
echo "fuzz: build took $((SECONDS - started)) s"

rm -rf "$work"
mkdir -p "$work" "$artifacts"

# One target: its own corpus copy, artifacts prefixed with its name, a status line.
run_target() {
  local target="$1"
  local corpus="$work/corpus/$target"
  mkdir -p "$corpus"
  if [[ -d "fuzz/corpus/$target" ]]; then
    cp -r "fuzz/corpus/$target/." "$corpus/"
  fi
  rm -f "$artifacts/$target"-*
  local status=0
  # -timeout: one input running 10 s is a hang; -malloc_limit_mb: one allocation over
  # 512 MiB comes from an unchecked length. Undefined behaviour aborts (-fno-sanitize-recover).
  ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=0" \
    UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
    "$build/fuzz/$target" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=512 -artifact_prefix="$artifacts/$target-" -print_final_stats=1 \
    >"$work/$target.log" 2>&1 || status=$?
  echo "$status" >"$work/$target.status"
}

running=()
for target in "${targets[@]}"; do
  if [[ ! -x "$build/fuzz/$target" ]]; then
    echo "fuzz: no target $target" >&2
    exit 2
  fi
  run_target "$target" &
  running+=($!)
  if ((${#running[@]} >= jobs)); then
    wait "${running[0]}"
    running=("${running[@]:1}")
  fi
done
wait

failed=0
for target in "${targets[@]}"; do
  status="$(cat "$work/$target.status")"
  log="$work/$target.log"
  runs="$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)"
  rate="$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)"
  if [[ "$status" == 0 ]]; then
    printf 'fuzz: %-18s ok   %8s runs %6s exec/s\n' "$target" "${runs:-?}" "${rate:-?}"
    continue
  fi
  failed=1
  kind="$(grep -m1 -oE 'ERROR: [A-Za-z]+: [A-Za-z0-9 -]+|runtime error: .*' "$log" ||
    echo "exit status $status")"
  echo "fuzz: $target FAILED: $kind"
  for reproducer in "$artifacts/$target"-*; do
    [[ -e "$reproducer" ]] || continue
    echo "fuzz:   reproducer $reproducer"
    echo "fuzz:   rerun: $build/fuzz/$target $reproducer"
  done
  echo "fuzz:   log $log (last lines below)"
  tail -n 30 "$log" | sed 's/^/    /'
done
echo "fuzz: $((SECONDS - started)) s in all (build and ${#targets[@]} targets, $seconds s each)"
exit "$failed"
