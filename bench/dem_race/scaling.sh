#!/usr/bin/env bash
# How the DEM engine's cost grows with the particle count (issue 3: "report how the cost grows
# with particle count, 1k to 200k"): dem_race's contact-only bed and bonded-fillet scenarios
# from about 1,000 to 200,000 particles, on one and two threads, the same timestep as the race
# (run.sh). Prints one TSV row per run and writes BUILD_DIR/dem_scaling/scaling.tsv, with the
# nanoseconds per particle-step.
#
# Usage: bench/dem_race/scaling.sh [BUILD_DIR]    (default build/release; needs target dem_race)
#   STEPS=N   timed steps per run (default 500; settling is as many again)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build/release}" && pwd)
race=$build/twin/dem_race
[[ -x $race ]] || { echo "dem_race missing: cmake --build $build --target dem_race" >&2; exit 2; }
steps=${STEPS:-500}
out=$build/dem_scaling
mkdir -p "$out"
table=$out/scaling.tsv
printf "code\tscenario\tN\tbonds\tcores\tsteps\twall_s\tparticle_steps_per_s\tcontact_coord\tns_per_particle_step\n" \
  >"$table"
run() {
  echo "dem_race $*" >&2
  "$race" "$@" --settle "$steps" --steps "$steps" |
    awk -F'\t' -v OFS='\t' '{print $0, sprintf("%.1f", 1e9 / $8)}' | tee -a "$table"
}
# bed: nx x ny x nz spheres of 4 mm; fillets: 350 spheres each
for threads in 1 2; do
  for size in "10 10 10" "25 20 10" "50 25 8" "100 50 10" "200 100 10"; do
    read -r nx ny nz <<<"$size"
    run --scenario bed --tag "bed$((nx * ny * nz))_np$threads" --nx "$nx" --ny "$ny" --nz "$nz" \
      --threads "$threads"
  done
  for fillets in 4 14 56 224 572; do
    run --scenario fillets --tag "fillets$((fillets * 350))_np$threads" --fillets "$fillets" \
      --threads "$threads"
  done
done
echo "written: $table"
