#!/usr/bin/env bash
# CTest driver for the @mcap/core interoperability check (label: interop).
#   run_interop.sh TOOL INTEROP_DIR WORK_DIR [RECORDING...]
# RECORDING: camera recordings of linectl record, opened with @mcap/core as Foxglove would.
# Exit 77 (CTest: skipped) without node or without the node modules; install them with
#   npm ci --prefix vision/mcap/interop
set -euo pipefail
tool=$1 interop_dir=$2 work_dir=$3
shift 3

if ! command -v node >/dev/null; then
  echo "SKIP: node is not installed"
  exit 77
fi
if [[ ! -d $interop_dir/node_modules/@mcap/core ]]; then
  echo "SKIP: $interop_dir/node_modules missing; run: npm ci --prefix vision/mcap/interop"
  exit 77
fi

rm -rf "$work_dir"
mkdir -p "$work_dir"
echo "== fl_mcap writes, @mcap/core reads"
"$tool" write "$work_dir"
node "$interop_dir/interop.mjs" read "$work_dir"/ours_none.mcap "$work_dir"/ours_zstd.mcap \
  "$work_dir"/ours_lz4.mcap
echo "== @mcap/core writes, fl_mcap reads"
node "$interop_dir/interop.mjs" write "$work_dir"
"$tool" check "$work_dir"/theirs_none.mcap
"$tool" check "$work_dir"/theirs_zstd.mcap
if [[ $# -gt 0 ]]; then
  echo "== the project's recordings, opened with @mcap/core"
  node "$interop_dir/interop.mjs" recording "$@"
fi
echo "interop: all files agree"
