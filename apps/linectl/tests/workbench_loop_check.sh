#!/usr/bin/env bash
# CTest driver for the workbench loop on the command line (apps/linectl/CMakeLists.txt):
#   workbench_loop_check.sh LINECTL DEM_CONFIG WORKDIR
# A drop dataset with a hidden bond effect; compare fails it; diagnose names the effect; the
# user adds it to a copy of config/dem.yaml (the change diagnose prints); compare again into
# the same folder: the error falls by 70 % or more and the history keeps both runs.
set -u
linectl=$1 dem_config=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
run() { "$linectl" "$@" >>"$work/log.txt" 2>&1 || { tail -20 "$work/log.txt"; fail "linectl $*"; }; }

run dataset generate --experiment drop --effect bpm_plastic --seed 41 --out "$work/drop"
run compare "$work/drop" --dem-config "$dem_config" --out "$work/compare"
run diagnose "$work/drop" --dem-config "$dem_config" --out "$work/diagnose"

# The proposed effect from diagnosis.json.
law=$(python3 - "$work/diagnose/diagnosis.json" <<'PY'
import json, sys
ranked = json.load(open(sys.argv[1]))["ranked"]
proposed = [r for r in ranked if r["proposed"]]
print(proposed[0]["law"] if proposed else "")
PY
)
[ "$law" = bpm_plastic ] || fail "diagnose proposed '${law}', the hidden effect is bpm_plastic"
grep -q "to add it, make this the bond_law" "$work/log.txt" || fail "diagnose did not say how to add it"
snippet="$work/diagnose/effect.yaml"
[ -s "$snippet" ] || fail "diagnose wrote no $snippet"

# The config change as a user makes it: the bond_law block replaced by the one diagnose wrote.
awk -v snippet="$snippet" '
  replacing && /^      / { next }
  { replacing = 0 }
  /^    bond_law:/ { while ((getline line < snippet) > 0) print line; replacing = 1; next }
  { print }' "$dem_config" >"$work/dem.yaml"
grep -q "law: bpm_plastic" "$work/dem.yaml" || fail "the bond law was not found in $dem_config"
run compare "$work/drop" --dem-config "$work/dem.yaml" --out "$work/compare"

python3 - "$work/compare/history.csv" <<'PY' || fail "the error did not fall"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert len(rows) == 2, f"{len(rows)} runs in the history, expected 2"
before, after = (float(r["rmse_si"]) for r in rows)
print(f"height RMS {before * 1e3:.3f} mm -> {after * 1e3:.3f} mm")
assert "bpm_plastic" in rows[1]["model"], rows[1]["model"]
assert rows[0]["effects"] == "none", rows[0]["effects"]
assert rows[1]["effects"].startswith("bpm_plastic (") and "normal_yield_strength_pa" in rows[1]["effects"], rows[1]["effects"]
assert after <= 0.3 * before, "less than a 70 % fall"
PY
[ -s "$work/compare/history.svg" ] && [ -s "$work/compare/report.html" ] || fail "report files"
echo "OK: bpm_plastic found and added; the error fell"
