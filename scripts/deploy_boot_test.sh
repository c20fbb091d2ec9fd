#!/usr/bin/env bash
# The Debian package booted under a live systemd (docs/deployment.md, "Boot test under systemd"):
#   1. builds the package as scripts/deploy_test.sh does (cpack DEB from BUILD_DIR, for /usr),
#   2. unpacks the cached clean Debian 12 root (debootstrap minbase + systemd, shared with
#      deploy_test.sh) and installs there with apt: the package, linux-image-amd64, udev,
#      initramfs-tools (an initramfs that mounts a virtio disk) and systemd-sysv,
#   3. enables fillet-line.service and a one-shot check unit, fillet-boot-check.service, which
#      runs scripts/deploy_boot_check.sh in the guest after the boot,
#   4. makes an ext4 image of the root (mkfs.ext4 -d) and boots it in qemu (TCG, 2 CPUs,
#      2 GiB) with the root's kernel and initramfs, console on the serial port,
#   5. the guest checks the running service (active; scan runtime started with SCHED_FIFO 80,
#      locked memory and cpu_dma_latency 0 us; the main process as fillet-line with exactly
#      CAP_SYS_NICE + CAP_IPC_LOCK), lets it run 20 s, stops it (SIGTERM drains the line;
#      ledger and KPIs written, clean exit), restarts it with a broken line.yaml (refused in
#      ExecStartPre with file and line in the journal); then starts fillet-line-control.service
#      on vcan0 (made by systemd-networkd at boot) against the twin's emulated CANopen devices
#      (linectl twin serve --can vcan0): the same start-up and privilege checks, its CANopen
#      start-up, 20 s of the line without a fault, a clean stop, the twin's books balanced;
#      writes its results as a tar archive onto a second virtio disk and powers off,
#   6. the host reads that disk, prints every check, checks the KPIs and the ledger.
# Exit 0 only if every check passed. Needs root (chroot, mounts), debootstrap, qemu-system-x86
# and e2fsprogs. Kept under build/deploy-test/boot/: the console log (console.log), the
# results (results/: results.txt, journal excerpts, both units' ledgers and KPIs, the twin's log), the apt log.
#   scripts/deploy_boot_test.sh [BUILD_DIR]     (default build/release)
#   FL_BOOT_TIMEOUT_S=900   cap for the qemu run (boot, checks, power-off)
#   FL_BOOT_KEEP_IMAGE=1    keep the root image (boot/root.ext4, about 2 GB) after the run
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-build/release}
label="deploy boot test"
root=build/deploy-test/boot-root
# say, fail, build_package, ensure_base, unpack_root, in_root, cleanup_root; work, base, mirror
source scripts/deploy_common.sh
boot=$work/boot
console=$boot/console.log
results=$boot/results
boot_timeout_s=${FL_BOOT_TIMEOUT_S:-900}

require_root_and_debootstrap
command -v qemu-system-x86_64 >/dev/null || fail "qemu-system-x86_64 missing (apt-get install qemu-system-x86)"
command -v mkfs.ext4 >/dev/null || fail "mkfs.ext4 missing (apt-get install e2fsprogs)"
boot_cleanup() {
  cleanup_root
  [[ ${FL_BOOT_KEEP_IMAGE:-0} == 1 ]] || rm -f "$boot/root.ext4"
}
trap boot_cleanup EXIT
rm -rf "$boot"
mkdir -p "$boot"

build_package "$build_dir"
ensure_base
unpack_root

# The initramfs only has to find a virtio disk with ext4 on it: MODULES=list with these
# modules is much smaller and faster to build than Debian's MODULES=most. Written before the
# kernel is installed, whose postinst builds the initramfs.
mkdir -p "$root/etc/initramfs-tools/conf.d" "$root/etc/initramfs-tools/hooks"
cat >"$root/etc/initramfs-tools/conf.d/fillet-boot-test.conf" <<'EOF'
MODULES=list
COMPRESS=gzip
RESUME=none
EOF
cat >"$root/etc/initramfs-tools/hooks/fillet-boot-test" <<'EOF'
#!/bin/sh
case "$1" in prereqs) exit 0 ;; esac
. /usr/share/initramfs-tools/hook-functions
force_load virtio_pci
force_load virtio_blk
manual_add_modules ext4 crc32c_generic
EOF
chmod 0755 "$root/etc/initramfs-tools/hooks/fillet-boot-test"
cat >"$root/etc/fstab" <<'EOF'
/dev/vda / ext4 rw,errors=remount-ro 0 0
EOF
echo fillet-line-pc >"$root/etc/hostname"

say "apt install $(basename "$deb") linux-image-amd64 udev initramfs-tools systemd-sysv"
in_root apt-get update -q >/dev/null
in_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
  "/tmp/$(basename "$deb")" linux-image-amd64 udev initramfs-tools systemd-sysv \
  >"$boot/apt-install.log" 2>&1 ||
  { tail -30 "$boot/apt-install.log"; fail "apt-get install (log: $boot/apt-install.log)"; }
grep -E '^[0-9]+ upgraded' "$boot/apt-install.log"
kernel=$(find "$root/boot" -name 'vmlinuz-*' | head -1)
initrd=$(find "$root/boot" -name 'initrd.img-*' | head -1)
[[ -n $kernel && -n $initrd ]] || fail "no kernel or initramfs in $root/boot"
cp "$kernel" "$boot/vmlinuz"
cp "$initrd" "$boot/initrd.img"
echo "kernel $(basename "$kernel"), initramfs $(du -h "$boot/initrd.img" | cut -f1)"

say "enable fillet-line.service and the check unit fillet-boot-check.service"
install -m 0755 scripts/deploy_boot_check.sh "$root/usr/local/sbin/fillet-boot-check"
cat >"$root/etc/systemd/system/fillet-boot-check.service" <<'EOF'
[Unit]
Description=fillet-line boot test: check the service, write the results to /dev/vdb, power off
After=fillet-line.service

[Service]
Type=oneshot
ExecStart=/usr/local/sbin/fillet-boot-check
StandardOutput=journal+console
StandardError=journal+console
TimeoutStartSec=20min

[Install]
WantedBy=multi-user.target
EOF
in_root systemctl enable fillet-line.service fillet-boot-check.service
# The CAN interface of fillet-line-control.service, set up as docs/deployment.md tells a site
# to set up can0: the CAN modules loaded at boot, the link made and brought up by
# systemd-networkd. vcan0 stands in for the CAN adapter; the twin's emulated CANopen devices
# (linectl twin serve --can vcan0, started by the check) are on the other end.
mkdir -p "$root/etc/systemd/network" "$root/etc/modules-load.d"
printf 'can\ncan_raw\nvcan\n' >"$root/etc/modules-load.d/can.conf"
cat >"$root/etc/systemd/network/80-vcan0.netdev" <<'EOF'
[NetDev]
Name=vcan0
Kind=vcan
EOF
cat >"$root/etc/systemd/network/80-vcan0.network" <<'EOF'
[Match]
Name=vcan0

[Link]
RequiredForOnline=no
EOF
in_root systemctl enable systemd-networkd.service >/dev/null 2>&1 ||
  fail "systemctl enable systemd-networkd in the root"
# The guest has no network card (qemu -nodefaults), so no link could ever come online: the wait
# would hold network-online.target, which the control unit is ordered after, for 2 minutes.
in_root systemctl mask systemd-networkd-wait-online.service >/dev/null 2>&1 || true
# Nothing else on the timers while the test runs.
in_root systemctl mask apt-daily.timer apt-daily-upgrade.timer e2scrub_all.timer fstrim.timer \
  >/dev/null 2>&1 || true
rm -f "$root/etc/resolv.conf"
unmount_root

say "ext4 image of the root (mkfs.ext4 -d)"
used_mb=$(du -sm "$root" | cut -f1)
image_mb=$((used_mb * 3 / 2 + 512))
rm -f "$boot/root.ext4"
truncate -s "${image_mb}M" "$boot/root.ext4"
mkfs.ext4 -q -F -L fillet-root -d "$root" "$boot/root.ext4" || fail "mkfs.ext4 -d $root"
echo "root $used_mb MB, image $image_mb MB"
cleanup_root
truncate -s 64M "$boot/results.img"

say "boot in qemu (TCG, 2 CPUs, 2 GiB; at most $boot_timeout_s s); guest lines:"
boot_start_s=$(date +%s)
set +e
timeout "$boot_timeout_s" qemu-system-x86_64 -accel tcg -cpu max -smp 2 -m 2048 \
  -nodefaults -no-user-config -nographic -serial stdio -monitor none -no-reboot \
  -kernel "$boot/vmlinuz" -initrd "$boot/initrd.img" \
  -append "console=ttyS0 root=/dev/vda rootfstype=ext4 rw panic=-1 mitigations=off net.ifnames=0" \
  -drive file="$boot/root.ext4",format=raw,if=virtio,cache=unsafe \
  -drive file="$boot/results.img",format=raw,if=virtio \
  -device virtio-rng-pci </dev/null 2>&1 | tee "$console" |
  grep --line-buffered -a -E 'BOOT-CHECK|Kernel panic|Reached target.*Multi-User' |
  sed -u -e 's/\r$//' -e 's/^/  /'
qemu_status=${PIPESTATUS[0]}
set -e
boot_s=$(($(date +%s) - boot_start_s))
[[ $qemu_status -eq 124 ]] && echo "qemu did not power off within $boot_timeout_s s"
say "qemu exited ($qemu_status) after $boot_s s; console log: $console"

mkdir -p "$results"
# A disk the guest never wrote is all zeros, which tar reads as an empty archive.
tar -C "$results" -xf "$boot/results.img" 2>/dev/null || true
[[ -f $results/results.txt ]] ||
  { tail -40 "$console"; fail "no results on the results disk (the guest's checks did not finish)"; }
rm -f "$boot/results.img"

say "results (guest: $results/results.txt; journal: $results/journal-fillet-line.txt)"
sed 's/^/  /' "$results/results.txt"
host_status=0
python3 - "$results/fillet-line-kpis.json" "$results/fillet-line-ledger.csv" <<'EOF' || host_status=1
import json, sys
try:
    kpis = json.load(open(sys.argv[1]))
    ledger_rows = sum(1 for _ in open(sys.argv[2])) - 1
except (OSError, ValueError) as error:
    print(f"  FAIL KPIs and ledger from the guest: {error}")
    sys.exit(1)
checks = {
    "ledger balanced": kpis["ledger"]["balanced"],
    "ground truth balanced": kpis["truth"]["balanced"],
    "fillets fed": kpis["truth"]["fed"] >= 10,
    "none lost": kpis["ledger"]["outcomes"]["lost"] == 0,
    "one ledger row per closed item": ledger_rows == kpis["ledger"]["items_closed"],
}
print(f"  KPIs after the stop: fed {kpis['truth']['fed']}, placed/min "
      f"{kpis['placed_per_minute']:.1f}, in spec "
      f"{100 * kpis['in_spec_share_of_singulated']:.1f} %, ledger rows {ledger_rows}")
for name, ok in checks.items():
    print(f"  {'PASS' if ok else 'FAIL'} {name}")
sys.exit(0 if all(checks.values()) else 1)
EOF
grep -q '^RESULT PASS' "$results/results.txt" || fail "checks in the guest failed (above; $results)"
[[ $host_status -eq 0 ]] || fail "KPI and ledger checks on the host"
say "passed in $(($(date +%s) - start_s)) s (qemu boot, checks and power-off $boot_s s)"
