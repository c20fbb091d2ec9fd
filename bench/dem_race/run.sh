#!/usr/bin/env bash
# The DEM speed race: our engine against LIGGGHTS, LAMMPS and Yade, side by side in one run on
# one machine. Runs ../shared/bench/run_peers.sh (from a copy: ../shared is read-only), then
# our dem_race command on the same scenarios with the same timestep and step counts, and writes
# one table (markdown) of particle-steps per second.
#
# Usage: bench/dem_race/run.sh [BUILD_DIR]       (default build/release; needs target dem_race)
#   QUICK=1    skip the 50k, 160k and 157k cases (peers and ours), about 12 min instead of 45
#   INSTALL=0  do not apt-get the peer codes (already installed)
#   PEERS=0    ours only
# Output: BUILD_DIR/dem_race/{peers.tsv,ours.tsv,race.md,load.txt}
set -euo pipefail
source "$(dirname "$0")/common.sh" "${1:-}" dem_race

if [[ ${PEERS:-1} == 1 ]]; then
  cp -r "$shared/bench" "$work/peers"
  chmod -R u+w "$work/peers"
  (cd "$work/peers" && QUICK=${QUICK:-0} INSTALL=${INSTALL:-1} bash run_peers.sh) |
    tee "$work/peers.log"
  cp "$work/peers/results.tsv" "$work/peers.tsv"
fi
echo "peers done: $(date -u +%FT%TZ) $(uptime)" >>"$work/load.txt"

ours=$work/ours.tsv
printf "code\tscenario\tN\tbonds\tcores\tsteps\twall_s\tparticle_steps_per_s\tcontact_coord\n" \
  >"$ours"
run() {
  echo "ours: $*" >&2
  "$race" "$@" | tee -a "$ours"
}
# the peers' step counts (run_peers.sh): settle 3000 + 3000 timed; 160k bed 3000 + 2000;
# 157k fillets 2000 + 2000
run --scenario bed --tag bed10k_np1 --nx 50 --ny 25 --nz 8 --threads 1
run --scenario bed --tag bed10k_np2 --nx 50 --ny 25 --nz 8 --threads 2
run --scenario fillets --tag fillets4900_np1 --fillets 14 --threads 1
run --scenario fillets --tag fillets4900_np2 --fillets 14 --threads 2
run --scenario fillets_jkr --tag fillets4900_jkr_np1 --fillets 14 --threads 1
if [[ ${QUICK:-0} != 1 ]]; then
  run --scenario bed --tag bed50k_np1 --nx 100 --ny 50 --nz 10 --threads 1
  run --scenario bed --tag bed50k_np2 --nx 100 --ny 50 --nz 10 --threads 2
  run --scenario bed --tag bed160k_np2 --nx 200 --ny 100 --nz 8 --threads 2 --steps 2000
  run --scenario fillets --tag fillets157k_np1 --fillets 450 --threads 1 --settle 2000 --steps 2000
  run --scenario fillets --tag fillets157k_np2 --fillets 450 --threads 2 --settle 2000 --steps 2000
fi
echo "end: $(date -u +%FT%TZ) $(uptime)" >>"$work/load.txt"

python3 "$root/bench/dem_race/table.py" "$work/peers.tsv" "$ours" >"$work/race.md"
cat "$work/race.md"
echo "written: $work/race.md"
