#!/usr/bin/env bash
# CTest driver of the HMI end-to-end test (label: hmi): linectl runs the controller in real
# time against the fast plant with the HMI on a free loopback port, and hmi_e2e.mjs drives the
# page in headless Chromium.
#   run_e2e.sh LINECTL E2E_DIR WORK_DIR
# Exit 77 (CTest: skipped) without node, chromium or the node modules; install them with
#   bash scripts/setup.sh   (apt chromium; npm ci --prefix hmi/tests/e2e)
set -euo pipefail
linectl=$1 e2e_dir=$2 work_dir=$3
chromium=${CHROMIUM:-/usr/bin/chromium}

if ! command -v node >/dev/null; then
  echo "SKIP: node is not installed"
  exit 77
fi
if [[ ! -x $chromium ]]; then
  echo "SKIP: $chromium missing; apt-get install chromium (or set CHROMIUM)"
  exit 77
fi
if [[ ! -d $e2e_dir/node_modules/playwright-core ]]; then
  echo "SKIP: $e2e_dir/node_modules missing; run: npm ci --prefix hmi/tests/e2e"
  exit 77
fi

rm -rf "$work_dir"
mkdir -p "$work_dir"
password="e2e operator $RANDOM$RANDOM"
# Few iterations: the test logs in a handful of times; production hashes use the default.
hash=$(printf '%s\n' "$password" | "$linectl" hmi hash-password --iterations 1000 2>/dev/null)
port=$(node -e 'const s=require("net").createServer().listen(0,"127.0.0.1",()=>{console.log(s.address().port);s.close();});')
cat >"$work_dir/hmi.yaml" <<YAML
bind_address: 127.0.0.1
port: $port
publish_rate_hz: 10
session_idle_timeout_s: 300
operator:
  user: operator
  password_hash: "$hash"
YAML

# SCHED_FIFO where allowed (root, CAP_SYS_NICE): Chromium starting on a busy machine must not
# starve the scan into its stall watchdog; without the privilege the run goes on without it.
"$linectl" run --plant fast --duration 10m --seed 1 --realtime --fifo 50 --quiet \
  --hmi "$work_dir/hmi.yaml" >"$work_dir/linectl.log" 2>&1 &
linectl_pid=$!
# The first TERM stops the line and lets the belts drain; a second one ends the run at once.
stop_linectl() {
  local signal
  for signal in TERM TERM KILL; do
    kill -0 "$linectl_pid" 2>/dev/null || return 0
    kill "-$signal" "$linectl_pid" 2>/dev/null || true
    for _ in $(seq 1 25); do
      kill -0 "$linectl_pid" 2>/dev/null || return 0
      sleep 0.2
    done
  done
}
trap stop_linectl EXIT

status=0
CHROMIUM=$chromium node "$e2e_dir/hmi_e2e.mjs" "http://127.0.0.1:$port" operator "$password" \
  "$work_dir" || status=$?
if ((status != 0)); then
  echo "== linectl log (tail)"
  tail -n 40 "$work_dir/linectl.log"
fi
exit "$status"
