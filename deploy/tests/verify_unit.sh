#!/usr/bin/env bash
# systemd-analyze verify on the fillet-line unit as installed: the build is installed into a
# scratch folder (DESTDIR) and the unit verified with its paths (linectl, the environment
# file) pointed into that folder, so that ExecStart and the unit's settings are checked as on
# the line PC against the host's systemd units.
#   verify_unit.sh BUILD_DIR SCRATCH_DIR UNIT_PATH      exit 77: skipped
set -euo pipefail
build_dir=$1 root=$2 unit=$3

if ! command -v systemd-analyze >/dev/null; then
  echo "SKIPPED: systemd-analyze not found (Debian: apt-get install systemd)"
  exit 77
fi
rm -rf "$root"
DESTDIR="$root" cmake --install "$build_dir" >/dev/null
# The installed unit with its absolute paths (/usr/bin/linectl, /etc/default/...) moved into
# the scratch folder; the rest of the unit is verified as shipped.
checked="$root/check/$(basename "$unit")"
mkdir -p "$(dirname "$checked")"
sed -E "s#^(ExecStart(Pre)?=|EnvironmentFile=)(-?)/#\\1\\3$root/#" "$root$unit" >"$checked"
# Some problems (unknown keys, bad values) are only warnings with a zero exit status: any
# output fails the test.
output=$(systemd-analyze verify "$checked" 2>&1) || {
  echo "$output"
  echo "FAILED: systemd-analyze verify $unit"
  exit 1
}
if [[ -n "$output" ]]; then
  echo "$output"
  echo "FAILED: systemd-analyze verify $unit reported problems"
  exit 1
fi
echo "systemd-analyze verify $unit: clean"
