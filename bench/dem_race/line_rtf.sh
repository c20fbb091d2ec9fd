#!/usr/bin/env bash
# The DEM line's pace against its load (issue 3: the real-time factor with about 20 fillets on
# the belts, at 7 mm): `linectl run --plant dem` at the shipped takt (a stroke at most every
# 0.9 s: 12 or 13 fillets on the line) and at a takt that keeps about 20 on it (every 0.5 s),
# same seed, one after the other. Prints each run's overall factor, its slowest second and its
# pace by the fillets on the line (linectl's JSON, pace_by_fillets_on_line).
#
#   bench/dem_race/line_rtf.sh [BUILD_DIR] [DURATION]      (default build/release, 60s)
#   OUT=dir   where the configuration copy and the JSON go (default a temporary folder)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build/release}" && pwd)
duration=${2:-60s}
linectl=$build/apps/linectl/linectl
[[ -x $linectl ]] || { echo "line_rtf.sh: $linectl not built" >&2; exit 2; }
out=${OUT:-$(mktemp -d)}
mkdir -p "$out/dense"
cp "$root"/config/*.yaml "$out/dense/"
# The takt's rate cap only; the 200 mm gap behind the previous item still holds.
sed -i 's/^  min_period_s: .*/  min_period_s: 0.5/' "$out/dense/line.yaml"
grep -q '^  min_period_s: 0.5$' "$out/dense/line.yaml" ||
  { echo "line_rtf.sh: takt.min_period_s not found in line.yaml" >&2; exit 2; }
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)," \
  "load $(cut -d' ' -f1-3 /proc/loadavg); build $(git -C "$root" rev-parse --short HEAD)"
for takt in shipped dense; do
  config_dir=$root/config
  [[ $takt == dense ]] && config_dir=$out/dense
  echo "== $takt takt: linectl run --plant dem --duration $duration --seed 1"
  FL_CONFIG_DIR=$config_dir "$linectl" run --plant dem --duration "$duration" --seed 1 --quiet \
    --config "$config_dir/line.yaml" --json "$out/$takt.json"
  python3 - "$out/$takt.json" <<'PY'
import json, sys
k = json.load(open(sys.argv[1]))
s = k["slowest_second"]
print(f"  overall {k['realtime_factor']:.2f}x ({k['total_simulated_s']:.1f} s in {k['wall_s']:.1f} s),"
      f" slowest second {s['realtime_factor']:.2f}x at {s['at_s']:.0f} s with {s['fillets_on_line']} fillets,"
      f" in spec {100 * k['in_spec_share_of_singulated']:.1f} %")
print("  fillets on the line: seconds, pace")
for load in k["pace_by_fillets_on_line"]:
    print(f"    {load['fillets_on_line']:3d}: {load['seconds']:3d} s, {load['realtime_factor']:.2f}x")
PY
done
echo "JSON in $out"
