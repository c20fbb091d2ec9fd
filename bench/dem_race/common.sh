# Sourced by the race scripts: the repository, the build folder (first argument, default
# build/release), ../shared and the dem_race command, and a fresh output folder under the build.
# Usage: source common.sh BUILD_DIR OUTPUT_NAME
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "${1:-$root/build/release}" && pwd)
shared=${FL_SHARED:-$root/../shared}
race=$build/twin/dem_race
[[ -x $race ]] || { echo "dem_race missing: cmake --build $build --target dem_race" >&2; exit 2; }
work=$build/$2
rm -rf "$work"
mkdir -p "$work"
# load.txt: the machine and its load when the run starts (the scripts add lines as they go)
{ echo "start: $(date -u +%FT%TZ) $(uptime)"; nproc; grep -m1 'model name' /proc/cpuinfo; } \
  >"$work/load.txt"
