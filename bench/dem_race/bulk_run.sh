#!/usr/bin/env bash
# The thesis' bulk-run size alone, side by side: LAMMPS and our engine on the 157,500-sphere
# bonded fillets (450 blocks), two cores each, with the peers' own input and step counts
# (../shared/bench/run_peers.sh: 2000 settle + 2000 timed). The full race (run.sh without QUICK)
# has this case too but takes about 45 minutes; this takes about 10.
#
# Usage: bench/dem_race/bulk_run.sh [BUILD_DIR]    (default build/release; needs dem_race, lmp)
# Output: BUILD_DIR/dem_race_bulk/{results.tsv,load.txt}, and the thesis' 15 s run estimated
# from each figure (89,365 steps of 157,500 particles).
set -euo pipefail
command -v lmp >/dev/null || { echo "lmp missing: INSTALL=1 bash bench/dem_race/run.sh first" >&2; exit 2; }
source "$(dirname "$0")/common.sh" "${1:-}" dem_race_bulk
cp -r "$shared/bench/lammps" "$work/lammps"
chmod -R u+w "$work/lammps"
results=$work/results.tsv
printf "code\tscenario\tN\tbonds\tcores\tsteps\twall_s\tparticle_steps_per_s\n" >"$results"

echo "== LAMMPS fillets157k_np2 (2 MPI ranks)" >&2
(
  cd "$work/lammps"
  python3 gen_fillets.py 15 15 >/dev/null
  mpirun --allow-run-as-root --bind-to core -np 2 lmp -in in.fillets -var nsettle 2000 \
    -var nrun 2000 -var jkr 0 -var gamma 0 -var skin 0.002 -var vbelt 0.3 -var rest 1e-4 \
    -log log.fillets157k_np2 -echo none -screen none >/dev/null 2>&1
)
loop=$(grep 'Loop time' "$work/lammps/log.fillets157k_np2" | tail -1)
[[ -n $loop ]] || { echo "LAMMPS run failed: see $work/lammps/log.fillets157k_np2" >&2; exit 1; }
bonds=$(sed -n 's/.*bonds=\([0-9]*\).*/\1/p' "$work/lammps/log.fillets157k_np2" | tail -1)
echo "$loop" | awk -v b="${bonds:-0}" '{n=$12; gsub(",", "", n);
  printf "lammps\tfillets157k_np2\t%d\t%d\t2\t%d\t%.3f\t%.3e\n", n, b, $9, $4, n*$9/$4}' |
  tee -a "$results"
echo "after LAMMPS: $(date -u +%FT%TZ) $(uptime)" >>"$work/load.txt"

echo "== ours fillets157k_np2 (2 threads)" >&2
"$race" --scenario fillets --tag fillets157k_np2 --fillets 450 --threads 2 --settle 2000 \
  --steps 2000 | cut -f1-8 | tee -a "$results"
echo "end: $(date -u +%FT%TZ) $(uptime)" >>"$work/load.txt"

# The thesis' bulk run: 15 s at this timestep is 89,365 steps of 157,500 particles.
awk -F'\t' 'NR > 1 { printf "%s: the thesis 15 s bulk run would take %.0f min at %.3e\n",
  $1, 157500 * 89365 / $8 / 60, $8 }' "$results"
