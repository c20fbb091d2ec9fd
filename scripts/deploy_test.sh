#!/usr/bin/env bash
# The Debian package on a clean Debian 12 root (docs/deployment.md, "Deployment test"):
#   1. configures BUILD_DIR for /usr, builds linectl and the package with cpack (DEB),
#   2. unpacks a clean Debian 12 root (debootstrap minbase + systemd, as on a line PC; made
#      once from the host's Debian mirror and cached as a tarball under build/deploy-test/),
#   3. installs the .deb there with apt, which resolves its dependencies in the root,
#   4. in the root: the installed configuration passes `linectl config check`, a broken one
#      is refused naming file and line, a missing one names the folders searched, the unit
#      passes systemd-analyze verify, and the installed binary, as the fillet-line user, runs
#      `linectl run --plant fast --duration 30s --seed 1` to the end with sane KPIs.
# Needs root (chroot, mounts) and debootstrap. Downloaded packages are kept under
# build/deploy-test/apt-archives, so a rerun needs the network only for apt's indexes.
#   scripts/deploy_test.sh [BUILD_DIR]        (default build/release)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build/release}
label="deploy test"
root=build/deploy-test/root
# say, fail, build_package, ensure_base, unpack_root, in_root, cleanup_root; work, base, mirror
source scripts/deploy_common.sh

require_root_and_debootstrap
trap cleanup_root EXIT

build_package "$build_dir"
ensure_base
unpack_root

say "apt install $(basename "$deb") (dependencies resolved in the root)"
in_root apt-get update -q >/dev/null
in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
  "/tmp/$(basename "$deb")" >"$work/apt-install.log" 2>&1 ||
  { tail -30 "$work/apt-install.log"; fail "apt-get install of the package"; }
grep -E '^[0-9]+ upgraded' "$work/apt-install.log"

say "installed: user, folders, conffiles"
in_root getent passwd fillet-line || fail "no fillet-line user"
for folder in /var/lib/fillet-line /var/log/fillet-line; do
  owner=$(in_root stat -c '%U:%G %a' "$folder") || fail "$folder missing"
  [[ $owner == "fillet-line:fillet-line 750" ]] || fail "$folder is $owner"
done
if [[ -f $root/etc/fillet-line/hmi.yaml ]]; then
  mode=$(in_root stat -c '%U:%G %a' /etc/fillet-line/hmi.yaml)
  [[ $mode == "root:fillet-line 640" ]] || fail "hmi.yaml (operator password hash) is $mode"
fi
in_root dpkg-query --control-show fillet-line conffiles | grep -q '^/etc/fillet-line/line.yaml' ||
  fail "/etc/fillet-line/line.yaml is not a conffile"
# DDS Security on the plant network: the key's folder private to the service, and every plugin
# the installed security file names present in the root (libddsc0debian, a dependency).
mode=$(in_root stat -c '%U:%G %a' /etc/fillet-line/dds/security) || fail "no dds/security folder"
[[ $mode == "root:fillet-line 750" ]] || fail "/etc/fillet-line/dds/security is $mode"
plugins=$(grep -o 'path="[^"]*"' "$root/etc/fillet-line/dds/cyclonedds-security.xml" | cut -d'"' -f2)
[[ $(wc -w <<<"$plugins") -eq 3 ]] || fail "cyclonedds-security.xml names plugins: $plugins"
for plugin in $plugins; do
  [[ -f $root$plugin ]] || fail "cyclonedds-security.xml names $plugin, missing in the root"
done
for unit in fillet-line.service fillet-line-control.service; do
  in_root systemd-analyze verify /usr/lib/systemd/system/$unit ||
    fail "systemd-analyze verify on the installed $unit"
done

as_service_user() {
  in_root setpriv --reuid=fillet-line --regid=fillet-line --init-groups \
    env HOME=/var/lib/fillet-line sh -c "cd /var/lib/fillet-line && $*"
}

say "linectl config check on the installed configuration"
as_service_user linectl config check --plant fast || fail "config check of /etc/fillet-line"
# fillet-line-control.service's ExecStartPre: the installed can.yaml
as_service_user linectl config check --can || fail "config check --can of /etc/fillet-line"

say "a broken line.yaml is refused, naming file and line"
broken_line=$(grep -n -m1 'max_speed_mps:' "$root/etc/fillet-line/line.yaml" | cut -d: -f1)
cp "$root/etc/fillet-line/line.yaml" "$root/tmp/line.yaml.good"
sed -i "${broken_line}s/max_speed_mps: .*/max_speed_mps: -3.0/" "$root/etc/fillet-line/line.yaml"
status=0
output=$(as_service_user linectl config check 2>&1) || status=$?
echo "$output"
[[ $status -eq 2 ]] || fail "config check of a broken line.yaml exited $status, not 2"
grep -q "/etc/fillet-line/line.yaml:$broken_line:" <<<"$output" ||
  fail "the refusal does not name /etc/fillet-line/line.yaml:$broken_line"
cp "$root/tmp/line.yaml.good" "$root/etc/fillet-line/line.yaml"

say "a missing default file names the folders searched"
mv "$root/etc/fillet-line/plant_fast.yaml" "$root/tmp/plant_fast.yaml"
status=0
output=$(as_service_user linectl config check --plant fast 2>&1) || status=$?
echo "$output"
[[ $status -ne 0 ]] || fail "config check without plant_fast.yaml passed"
grep -q "plant_fast.yaml not found; searched (in order): /etc/fillet-line" <<<"$output" ||
  fail "the error does not name plant_fast.yaml and /etc/fillet-line"
mv "$root/tmp/plant_fast.yaml" "$root/etc/fillet-line/plant_fast.yaml"

say "the installed linectl as fillet-line: run --plant fast --duration 30s --seed 1"
as_service_user linectl run --plant fast --duration 30s --seed 1 --quiet \
  --json /var/lib/fillet-line/kpis.json --ledger /var/lib/fillet-line/ledger.csv \
  --log-file /var/log/fillet-line/linectl.log || fail "linectl run exited $?"
python3 - "$root/var/lib/fillet-line/kpis.json" "$root/var/lib/fillet-line/ledger.csv" <<'EOF'
import json, sys
kpis = json.load(open(sys.argv[1]))
ledger_rows = sum(1 for _ in open(sys.argv[2])) - 1
checks = {
    "ledger balanced": kpis["ledger"]["balanced"],
    "ground truth balanced": kpis["truth"]["balanced"],
    "fillets fed": kpis["truth"]["fed"] >= 20,
    "placed per minute over 30": kpis["placed_per_minute"] > 30.0,
    "in spec at least 90 %": kpis["in_spec_share_of_singulated"] >= 0.9,
    "none lost": kpis["ledger"]["outcomes"]["lost"] == 0,
    "one ledger row per closed item": ledger_rows == kpis["ledger"]["items_closed"],
}
print(f"KPIs: fed {kpis['truth']['fed']}, placed/min {kpis['placed_per_minute']:.1f}, "
      f"in spec {100 * kpis['in_spec_share_of_singulated']:.1f} %, ledger rows {ledger_rows}")
failed = [name for name, ok in checks.items() if not ok]
if failed:
    sys.exit("FAILED: KPI checks: " + ", ".join(failed))
EOF
[[ -s $root/var/log/fillet-line/linectl.log ]] || fail "no log file written"
owner=$(in_root stat -c '%U' /var/lib/fillet-line/ledger.csv)
[[ $owner == fillet-line ]] || fail "the ledger belongs to $owner"

say "reinstall keeps an edited conffile; purge removes the state and log folders"
echo "# edited on site" >>"$root/etc/fillet-line/line.yaml"
in_root env DEBIAN_FRONTEND=noninteractive dpkg -i "/tmp/$(basename "$deb")" >/dev/null ||
  fail "reinstalling the package"
grep -q "^# edited on site" "$root/etc/fillet-line/line.yaml" || fail "the edited line.yaml was replaced"
in_root env DEBIAN_FRONTEND=noninteractive apt-get purge -y -q fillet-line >/dev/null ||
  fail "purging the package"
for gone in /etc/fillet-line/line.yaml /var/lib/fillet-line /usr/bin/linectl; do
  [[ ! -e $root$gone ]] || fail "$gone is still there after purge"
done

say "passed in $(($(date +%s) - start_s)) s"
