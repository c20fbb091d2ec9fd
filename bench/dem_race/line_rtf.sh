#!/usr/bin/env bash
# The DEM line's pace against its load (issue 3: the real-time factor of the line from the takt
# to the end with about 20 fillets on the belts, at least 1.0 at 7 mm, as high as possible at
# 4 mm), one after the other:
#   1. the closed loop, `linectl run --plant dem --duration DURATION --seed 1`: what the
#      shipped takt and infeed put on the line (12 or 13 fillets), its overall factor, its
#      slowest second and its pace by the fillets on the line (pace_by_fillets_on_line);
#   2. dem_line_load at 1.75 fillets a second, the line held at about 20 (7 mm);
#   3. with FOUR_MM=1, the same at 4 mm (a copy of config/ with the sub-particle radius set).
#
#   bench/dem_race/line_rtf.sh [BUILD_DIR] [DURATION]      (default build/release, 60s)
#   OUT=dir   where the JSON and the configuration copy go (default a temporary folder)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build/release}" && pwd)
duration=${2:-60s}
linectl=$build/apps/linectl/linectl
load=$build/twin/dem_line_load
for tool in "$linectl" "$load"; do
  [[ -x $tool ]] || { echo "line_rtf.sh: $tool not built" >&2; exit 2; }
done
out=${OUT:-$(mktemp -d)}
mkdir -p "$out"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)," \
  "load $(cut -d' ' -f1-3 /proc/loadavg); build $(git -C "$root" rev-parse --short HEAD)"

echo "== 1. closed loop: linectl run --plant dem --duration $duration --seed 1"
"$linectl" run --plant dem --duration "$duration" --seed 1 --quiet --log-level error \
  --json "$out/closed_loop.json"
python3 - "$out/closed_loop.json" <<'PY'
import json, sys
k = json.load(open(sys.argv[1]))
s = k["slowest_second"]
print(f"  overall {k['realtime_factor']:.2f}x ({k['simulated_s']:.1f} s in {k['wall_s']:.1f} s),"
      f" slowest second {s['realtime_factor']:.2f}x at {s['at_s']:.0f} s with"
      f" {s['fillets_on_line']} fillets, in spec {100 * k['in_spec_share_of_singulated']:.1f} %")
print("  by fillets on the line (seconds, pace):",
      ", ".join(f"{l['fillets_on_line']}: {l['seconds']} s {l['realtime_factor']:.2f}x"
                for l in k["pace_by_fillets_on_line"] if l["fillets_on_line"] >= 8))
PY

echo "== 2. about 20 fillets, 7 mm: dem_line_load --rate 1.75 --warmup 14 --seconds 20"
"$load" --rate 1.75 --warmup 14 --seconds 20 2>/dev/null | tail -1

if [[ ${FOUR_MM:-0} == 1 ]]; then
  mkdir -p "$out/config4mm"
  cp "$root"/config/*.yaml "$out/config4mm/"
  # The plant and the line's bulk end must share the raster.
  sed -i 's/^\(\s*sub_particle_radius_mm:\) 7\.0/\1 4.0/' \
    "$out/config4mm/plant_dem.yaml" "$out/config4mm/bulk_line.yaml"
  echo "== 3. about 20 fillets, 4 mm: dem_line_load --rate 1.75 --warmup 14 --seconds 6"
  "$load" --rate 1.75 --warmup 14 --seconds 6 --config "$out/config4mm/plant_dem.yaml" \
    2>/dev/null | tail -1
fi
echo "JSON in $out"
