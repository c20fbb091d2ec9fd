#!/usr/bin/env bash
# CTest driver for linectl dataset from-recording (apps/linectl/CMakeLists.txt):
#   from_recording_check.sh LINECTL WORKDIR
# A 13 s recording of the DEM twin's closed loop (fillets reach the multilane units after about
# 10 s); its multilane cameras' tracks and the scans' log as a line-track dataset taken on the
# line; linectl compare replays it on the DEM plant. A truncated recording is refused.
set -u
linectl=$1 work=$2
rm -rf "$work"
mkdir -p "$work"
fail() { echo "FAIL: $*"; exit 1; }
run() { "$linectl" "$@" >>"$work/log.txt" 2>&1 || { tail -20 "$work/log.txt"; fail "linectl $*"; }; }

run record --plant dem --duration 13s --seed 1 --width 64 --height 48 --out "$work/run.mcap"
# The multilane cameras' noise (config/plant_fast.yaml): 2 mm, 0.015 rad.
run dataset from-recording "$work/run.mcap" --out "$work/tracks" --position-noise-mm 2 \
    --angle-noise-deg 0.86
grep -q "machine: line" "$work/tracks/manifest.yaml" || fail "the trials do not say machine: line"

python3 - "$work/tracks" <<'PY' || fail "the tracks are not the fillets the cameras saw"
import csv, glob, sys
# The cameras' views (config/line.yaml): multilane1 3600 +- 200 mm, multilane2 4000 +- 200 mm;
# a fillet's centre is seen within its view, a few millimetres of noise beyond at most.
views = {"multilane1": (3400, 3800), "multilane2": (3800, 4200)}
tracks = 0
for path in sorted(glob.glob(sys.argv[1] + "/multilane*_*.csv")):
    if path.endswith("_commands.csv"):
        header = open(path).readline()
        assert "multilane2_right [m/s]" in header and "flip_plate1 [1]" in header, header
        continue
    camera = path.split("/")[-1].split("_")[0]
    low, high = views[camera]
    rows = {}
    for row in csv.DictReader(open(path)):
        rows.setdefault(row["fillet [1]"], []).append(
            (float(row["time [s]"]), float(row["x [mm]"]), float(row["y [mm]"])))
    for fillet, track in rows.items():
        tracks += 1
        xs = [x for _, x, _ in track]
        assert all(low - 20 <= x <= high + 20 for x in xs), (path, fillet, min(xs), max(xs))
        # Carried along by the belt: forward from frame to frame but for the noise, and over at
        # least 5 frames (the default --min-rows) of 25 ms at about 0.6 m/s.
        assert all(b >= a - 10 for a, b in zip(xs, xs[1:])), (path, fillet)
        assert xs[-1] - xs[0] > 50, (path, fillet, xs[0], xs[-1])
    # One fillet, one track: no two tracks of a camera at the same time closer than a fillet's
    # width (72 mm).
    for a in rows:
        for b in rows:
            if a >= b: continue
            for ta, xa, ya in rows[a]:
                for tb, xb, yb in rows[b]:
                    if abs(ta - tb) < 1e-6:
                        assert ((xa - xb) ** 2 + (ya - yb) ** 2) ** 0.5 > 60, (path, a, b, ta)
assert tracks >= 2, tracks
print(tracks, "tracks")
PY

run compare "$work/tracks" --out "$work/compare"
[ -s "$work/compare/report.html" ] || fail "compare wrote no report"

head -c 2000 "$work/run.mcap" >"$work/truncated.mcap"
"$linectl" dataset from-recording "$work/truncated.mcap" --out "$work/none" >"$work/bad.txt" 2>&1
rc=$?
[ $rc -eq 2 ] || { cat "$work/bad.txt"; fail "a truncated recording gave exit status $rc, not 2"; }
grep -q "truncated.mcap" "$work/bad.txt" || fail "the refusal does not name the file"
[ ! -e "$work/none" ] || fail "a dataset was written from a truncated recording"
echo "from-recording: OK"
