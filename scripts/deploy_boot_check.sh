#!/bin/bash
# Runs once inside the guest that scripts/deploy_boot_test.sh boots (installed there as
# /usr/local/sbin/fillet-boot-check, started by fillet-boot-check.service after
# fillet-line.service). It checks the fillet-line service under the running systemd, then
# fillet-line-control.service on vcan0 against the twin's emulated CANopen devices, writes
# results.txt, journal excerpts, the ledgers and the KPIs as a tar archive onto the second disk
# (/dev/vdb, read by the host) and powers the guest off. Every line of results.txt is
# "PASS name: detail" or "FAIL name: detail", the last one "RESULT PASS|FAIL (...)".
set -u
out=/run/fillet-boot-check
results=$out/results.txt
mkdir -p "$out"
: >"$results"
failures=0
checks=0
unit=fillet-line.service
state_dir=/var/lib/fillet-line
line_yaml=/etc/fillet-line/line.yaml
# CAP_IPC_LOCK (14) and CAP_SYS_NICE (23), nothing else.
expected_caps=0000000000804000
start_wait_s=${FL_BOOT_START_WAIT_S:-300}
run_s=${FL_BOOT_RUN_S:-20}

note() { echo "BOOT-CHECK: $*"; }
record() {  # record PASS|FAIL name detail
  checks=$((checks + 1))
  [[ $1 == PASS ]] || failures=$((failures + 1))
  echo "$1 $2: $3" >>"$results"
  note "$1 $2: $3"
}
# expect name detail command...: PASS when the command succeeds
expect() {
  local name=$1 detail=$2
  shift 2
  if "$@"; then record PASS "$name" "$detail"; else record FAIL "$name" "$detail"; fi
}
unit_journal() { journalctl -b -u "$unit" -o cat --no-pager "$@" 2>/dev/null; }
prop() { systemctl show -p "$1" --value "$unit"; }
# The state folder's ledger and KPIs as they are now, under the unit's name (both units write
# the same two files).
keep_books() {
  for file in ledger.csv kpis.json; do
    [[ -f $state_dir/$file ]] && cp "$state_dir/$file" "$out/$1-$file"
  done
}

finish() {
  trap - EXIT
  journalctl -b -u fillet-line.service -o short-monotonic --no-pager >"$out/journal-fillet-line.txt" 2>&1
  journalctl -b -u fillet-line-control.service -o short-monotonic --no-pager \
    >"$out/journal-fillet-line-control.txt" 2>&1
  journalctl -b -o short-monotonic --no-pager -p warning >"$out/journal-warnings.txt" 2>&1
  journalctl -b -o short-monotonic --no-pager >"$out/journal-boot.txt" 2>&1
  systemctl status fillet-line.service fillet-line-control.service --no-pager -l \
    >"$out/status.txt" 2>&1
  systemctl list-units --failed --no-pager >"$out/failed-units.txt" 2>&1
  uname -a >"$out/uname.txt"
  if ((failures == 0 && checks > 0)); then verdict=PASS; else verdict=FAIL; fi
  echo "RESULT $verdict ($checks checks, $failures failed)" >>"$results"
  note "RESULT $verdict ($checks checks, $failures failed)"
  if [[ -b /dev/vdb ]]; then
    tar -C "$out" -cf /dev/vdb . && sync && note "results written to /dev/vdb"
  else
    note "no /dev/vdb: results only on the console"
  fi
  note "powering off"
  systemctl poweroff --no-block
}
trap finish EXIT

note "started at $(cut -d' ' -f1 /proc/uptime) s after boot; kernel $(uname -r)"

# The unit in $unit: its scan runtime starts with the real-time setup (waiting up to
# start_wait_s), and its main process runs as the fillet-line user with exactly CAP_SYS_NICE
# and CAP_IPC_LOCK, with what the start line claims as the kernel sees it. $1 prefixes the
# check names.
check_started() {
  local label=$1 start_line='' waited state uptime_s setup_warning
  for ((waited = 0; waited < start_wait_s; waited++)); do
    start_line=$(unit_journal | grep -m1 'scan runtime started' || true)
    [[ -n $start_line ]] && break
    [[ $(systemctl is-failed "$unit") == failed ]] && break
    sleep 1
  done
  state=$(systemctl is-active "$unit")
  uptime_s=$(cut -d' ' -f1 /proc/uptime)
  expect "${label}service active" "$unit is $state, $uptime_s s after boot" test "$state" = active
  expect "${label}scan runtime started" "${start_line:-no 'scan runtime started' line in the journal after ${waited} s}" \
    test -n "$start_line"
  expect "${label}SCHED_FIFO 80 in the start line" "reported" grep -q 'SCHED_FIFO 80' <<<"$start_line"
  expect "${label}memory locked in the start line" "reported" grep -q 'memory locked' <<<"$start_line"
  expect "${label}cpu_dma_latency 0 us in the start line" "reported" \
    grep -q 'cpu_dma_latency 0 us' <<<"$start_line"
  setup_warning=$(unit_journal | grep -m1 'real-time setup:' || true)
  expect "${label}no real-time setup warning" "${setup_warning:-none}" test -z "$setup_warning"
}

check_main_process() {
  local label=$1 pid user_id group_id status_file exe uids gids cap_eff cap_prm cap_bnd cap_amb
  local vm_lck fifo_threads task rt_priority policy dma_fd node
  pid=$(prop MainPID)
  user_id=$(id -u fillet-line 2>/dev/null || echo none)
  group_id=$(id -g fillet-line 2>/dev/null || echo none)
  status_file=/proc/$pid/status
  if [[ $pid == 0 || ! -r $status_file ]]; then
    record FAIL "${label}main process" "no main process (MainPID $pid)"
    return
  fi
  exe=$(readlink "/proc/$pid/exe")
  uids=$(awk '/^Uid:/ {print $2, $3, $4, $5}' "$status_file")
  gids=$(awk '/^Gid:/ {print $2, $3, $4, $5}' "$status_file")
  cap_eff=$(awk '/^CapEff:/ {print $2}' "$status_file")
  cap_prm=$(awk '/^CapPrm:/ {print $2}' "$status_file")
  cap_bnd=$(awk '/^CapBnd:/ {print $2}' "$status_file")
  cap_amb=$(awk '/^CapAmb:/ {print $2}' "$status_file")
  vm_lck=$(awk '/^VmLck:/ {print $2}' "$status_file")
  expect "${label}main process is /usr/bin/linectl" "pid $pid, $exe" test "$exe" = /usr/bin/linectl
  expect "${label}runs as fillet-line" "uid (real, effective, saved, fs) $uids, gid $gids; fillet-line is $user_id:$group_id" \
    test "$uids" = "$user_id $user_id $user_id $user_id" -a "$gids" = "$group_id $group_id $group_id $group_id"
  expect "${label}CapEff exactly cap_sys_nice + cap_ipc_lock" "CapEff $cap_eff (expected $expected_caps), CapPrm $cap_prm, CapAmb $cap_amb, CapBnd $cap_bnd" \
    test "$cap_eff" = "$expected_caps"
  expect "${label}memory locked (kernel)" "VmLck ${vm_lck:-?} kB" test "${vm_lck:-0}" -gt 0
  fifo_threads=()
  for task in /proc/"$pid"/task/*; do
    # After the command name: field 40 is rt_priority, 41 the policy (1: SCHED_FIFO).
    read -r rt_priority policy < <(sed 's/^.*) //' "$task/stat" | awk '{print $38, $39}')
    [[ $policy == 1 ]] && fifo_threads+=("${task##*/}:$rt_priority")
  done
  expect "${label}scan thread SCHED_FIFO 80 (kernel)" "SCHED_FIFO threads (tid:priority): ${fifo_threads[*]:-none}" \
    grep -qE '(^| )[0-9]+:80( |$)' <<<"${fifo_threads[*]:-}"
  dma_fd=$(for fd in /proc/"$pid"/fd/*; do readlink "$fd"; done | grep -c '^/dev/cpu_dma_latency$' || true)
  node=$(stat -c '%U:%G %a' /dev/cpu_dma_latency 2>&1)
  expect "${label}/dev/cpu_dma_latency held (udev rule, DeviceAllow)" "node $node, open in the main process: $dma_fd" \
    test "$node" = "root:fillet-line 660" -a "$dma_fd" -ge 1
}

# After `systemctl stop "$unit"` (its exit status $1; stop_begin and stop_since taken before it):
# a clean stop that drained the line after SIGTERM. $2 prefixes the check names; the stop's
# journal is left in stop_journal.
check_stopped() {
  local stop_rc=$1 label=$2 stop_s result main_code main_status undrained
  stop_s=$((SECONDS - stop_begin))
  result=$(prop Result)
  main_code=$(prop ExecMainCode)
  main_status=$(prop ExecMainStatus)
  expect "${label}systemctl stop" "exit $stop_rc after $stop_s s (TimeoutStopSec 90 s)" test "$stop_rc" = 0
  expect "${label}clean stop" "Result=$result, main process exit code $main_code (1: exited) status $main_status" \
    test "$result" = success -a "$main_code" = 1 -a "$main_status" = 0
  stop_journal=$(unit_journal --since "@$stop_since")
  expect "${label}SIGTERM stops the line and drains" "journal: $(grep -m1 -o 'stop requested by signal.*' <<<"$stop_journal" || echo 'no stop line')" \
    grep -q 'stop requested by signal' <<<"$stop_journal"
  undrained=$(grep -m1 -E 'before the belts were drained|timed out|Killing' <<<"$stop_journal" || true)
  expect "${label}drained, not killed" "${undrained:-no drain timeout, no kill}" test -z "$undrained"
}

# 1. The service comes up at boot under systemd, with its real-time setup and privileges.
check_started ""
check_main_process ""

# 2. Let the line run, then stop it: SIGTERM drains the belts and writes ledger and KPIs.
sleep "$run_s"
rows_running=$( (wc -l <"$state_dir/ledger.csv") 2>/dev/null || echo 0)
# A scan watchdog or overrun fault ends the run, and linectl then exits 0, so systemd does not
# restart it. Under TCG this has been seen right at the start ("scan thread stalled after 0
# scans": more than the watchdog's 10 periods between the start and the first scan).
fault=$(unit_journal | grep -m1 'runtime fault' || true)
expect "no scan runtime fault while running" "${fault:-none in $run_s s; $(systemctl is-active "$unit")}" \
  test -z "$fault"
stop_since=$(date +%s)
sleep 1
stop_begin=$SECONDS
systemctl stop "$unit"
check_stopped $? ""
ledger_rows=$( (wc -l <"$state_dir/ledger.csv") 2>/dev/null || echo 0)
ledger_owner=$(stat -c %U "$state_dir/ledger.csv" 2>/dev/null || echo missing)
expect "ledger written" "$state_dir/ledger.csv: $ledger_rows lines ($rows_running while running), owner $ledger_owner" \
  test "$ledger_rows" -ge 2 -a "$ledger_owner" = fillet-line
kpis_mtime=$(stat -c %Y "$state_dir/kpis.json" 2>/dev/null || echo 0)
balanced=$(grep -c '"balanced": true' "$state_dir/kpis.json" 2>/dev/null || echo 0)
expect "KPIs written at the stop" "$state_dir/kpis.json: written $((kpis_mtime - stop_since)) s after the stop request, $balanced of 2 books balanced" \
  test "$kpis_mtime" -ge "$stop_since" -a "$balanced" = 2
expect "KPIs logged" "journal: $(grep -m1 -o 'KPIs written to.*' <<<"$stop_journal" || echo 'no line')" \
  grep -q 'KPIs written to /var/lib/fillet-line/kpis.json' <<<"$stop_journal"
keep_books fillet-line

# 3. A broken line.yaml: the restart fails in ExecStartPre, naming file and line.
broken_line=$(grep -n -m1 'max_speed_mps:' "$line_yaml" | cut -d: -f1)
cp "$line_yaml" "$out/line.yaml.good"
sed -i "${broken_line}s/max_speed_mps: .*/max_speed_mps: -3.0/" "$line_yaml"
broken_since=$(date +%s)
sleep 1
systemctl restart "$unit" 2>"$out/restart.txt"
restart_rc=$?
sleep 2
state=$(systemctl is-active "$unit")
broken_journal=$(unit_journal --since "@$broken_since")
expect "restart with a broken line.yaml fails" "systemctl restart exit $restart_rc ($(head -1 "$out/restart.txt")), then $state" \
  test "$restart_rc" != 0 -a "$state" != active
expect "journal: invalid configuration" "$(grep -m1 -o 'invalid configuration.*' <<<"$broken_journal" || echo 'no such line')" \
  grep -q 'invalid configuration, nothing started' <<<"$broken_journal"
expect "journal: file and line" "$(grep -m1 -o "$line_yaml:[0-9]*:.*" <<<"$broken_journal" || echo "no $line_yaml:$broken_line: line")" \
  grep -q "$line_yaml:$broken_line:[0-9]*: .*max_speed_mps" <<<"$broken_journal"
expect "journal: ExecStartPre exit 2" "$(grep -m1 -o 'Control process exited.*' <<<"$broken_journal" || echo 'no such line')" \
  grep -q 'Control process exited, code=exited, status=2' <<<"$broken_journal"
restarted=$(grep -m1 'scan runtime started' <<<"$broken_journal" || true)
expect "linectl run not started" "${restarted:-no 'scan runtime started' after the restart}" \
  test -z "$restarted"
systemctl stop "$unit"
cp "$out/line.yaml.good" "$line_yaml"
systemctl reset-failed "$unit" 2>/dev/null || true

# 4. fillet-line-control.service, the controller on the line's devices, on the CAN interface
# the site set up (vcan0: networkd made it at boot from the root's .netdev, the CAN modules came
# from modules-load.d), with the twin's emulated CANopen drives and I/O and its cameras on the
# other end (linectl twin serve, as root beside the unit). The site's changes are the ones a
# site makes: the interface and the DDS configuration in the environment file, here the
# loopback one (no network card in the guest).
unit=fillet-line-control.service
env_file=/etc/default/fillet-line
can_yaml=/etc/fillet-line/can.yaml
dds_xml=/etc/fillet-line/dds/cyclonedds-loopback.xml
control_run_s=${FL_BOOT_CONTROL_RUN_S:-20}
vcan_flags=$(cat /sys/class/net/vcan0/flags 2>/dev/null || echo none)
vcan_type=$(cat /sys/class/net/vcan0/type 2>/dev/null || echo none)
# type 280 is ARPHRD_CAN; flag 0x1 is IFF_UP.
expect "vcan0 made and up by systemd-networkd" "type $vcan_type, flags $vcan_flags; $(networkctl list --no-pager --no-legend vcan0 2>&1 | tr -s ' ')" \
  test "$vcan_type" = 280 -a $((${vcan_flags/none/0} & 1)) = 1
cp "$env_file" "$out/default.good"
cp "$can_yaml" "$out/can.yaml.good"
sed -i -e 's/^LINECTL_CAN_INTERFACE=.*/LINECTL_CAN_INTERFACE=vcan0/' \
  -e "s|^#\?CYCLONEDDS_URI=.*|CYCLONEDDS_URI=file://$dds_xml|" "$env_file"
# Every heartbeat timeout four times longer, for the emulated CPUs (as the vcan smoke test
# does): a stall of the whole TCG guest is not a device falling silent.
awk '{ if (match($0, /heartbeat_timeout_ms: [0-9]+/)) {
         n = substr($0, RSTART + 22, RLENGTH - 22) * 4
         $0 = substr($0, 1, RSTART + 21) n substr($0, RSTART + RLENGTH) }
       print }' "$out/can.yaml.good" >"$can_yaml"
twin_log=$out/twin.log
env FL_CONFIG_DIR=/etc/fillet-line CYCLONEDDS_URI="file://$dds_xml" \
  /usr/bin/linectl twin serve --plant fast --seed 1 --can vcan0 --duration 180s --wait 300s \
  --json "$out/twin.json" >"$twin_log" 2>&1 &
twin_pid=$!
control_since=$(date +%s)
sleep 1
systemctl start "$unit" 2>"$out/control-start.txt"
start_rc=$?
expect "control: systemctl start" "exit $start_rc $(head -1 "$out/control-start.txt")" test "$start_rc" = 0
check_started "control: "
check_main_process "control: "
startup=""
for ((waited = 0; waited < start_wait_s; waited++)); do
  startup=$(unit_journal --since "@$control_since" | grep -m1 -o 'CANopen start-up in.*' || true)
  [[ -n $startup ]] && break
  [[ $(systemctl is-active "$unit") == active ]] || break
  sleep 1
done
expect "control: CANopen start-up on vcan0" "${startup:-no start-up line after $waited s}" test -n "$startup"
# Nothing heavy runs beside the line until it is stopped: reading the journal under TCG once
# stalled the emulated CPUs past the scan watchdog's 100 ms. The run's journal is judged after.
sleep "$control_run_s"
running_state=$(systemctl is-active "$unit")
expect "control: twin still serving" "twin pid $twin_pid" kill -0 "$twin_pid"
stop_since=$(date +%s)
sleep 1
stop_begin=$SECONDS
systemctl stop "$unit"
check_stopped $? "control: "
control_journal=$(unit_journal --since "@$control_since" --until "@$stop_since")
fault=$(grep -m1 -E 'runtime fault|fault raised|the line faulted' <<<"$control_journal" || true)
expect "control: no fault while running" "${fault:-none in $control_run_s s; $running_state}" \
  test -z "$fault" -a "$running_state" = active
balanced=$(grep -c '"balanced": true' "$state_dir/kpis.json" 2>/dev/null || echo 0)
kpis_mtime=$(stat -c %Y "$state_dir/kpis.json" 2>/dev/null || echo 0)
expect "control: KPIs written at the stop, ledger balanced" "$state_dir/kpis.json: written $((kpis_mtime - stop_since)) s after the stop request, $balanced balanced book" \
  test "$kpis_mtime" -ge "$stop_since" -a "$balanced" = 1
keep_books control
# The twin ends on its own once the line stopped and its belts are empty: exit 0 means the
# controller started the line, never fell silent while it ran, and every fillet the twin fed is
# accounted for.
twin_rc=timeout
for ((waited = 0; waited < 120; waited++)); do
  if ! kill -0 "$twin_pid" 2>/dev/null; then
    wait "$twin_pid"
    twin_rc=$?
    break
  fi
  sleep 1
done
[[ $twin_rc == timeout ]] && kill "$twin_pid" 2>/dev/null
expect "control: twin ended with its books balanced" "linectl twin serve exit $twin_rc; $(grep -m1 -E '^twin ' "$twin_log" || tail -1 "$twin_log")" \
  test "$twin_rc" = 0
cp "$out/default.good" "$env_file"
cp "$out/can.yaml.good" "$can_yaml"
