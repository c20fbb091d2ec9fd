#!/usr/bin/env bash
# clang-tidy (the repo's .clang-tidy) over every project source in a build's compile database,
# failing on any finding. Usage: bash scripts/tidy.sh [BUILD_DIR] [FILE_REGEX]
#   BUILD_DIR   a configured build (default build/release; scripts/build.sh release makes it)
#   FILE_REGEX  only the sources whose path matches (default: all of them)
# The whole tree took 37 minutes with one job beside other work (2026-12-03, 2-core VM), so it
# is a developer's check and not a CI stage (CI's 90 minutes are mostly spent already); run it
# on what you touched, for example
#   bash scripts/tidy.sh build/release 'twin/src/dem/'
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}
only=${2:-}
if [[ ! -f $build/compile_commands.json ]]; then
  echo "tidy: $build/compile_commands.json not found; configure the build first" \
    "(bash scripts/build.sh release)" >&2
  exit 2
fi
root=$(pwd)
components='apps|bench|controller|drivers|hil_tests|hmi|report|twin|vision|workbench'
# Sources of the project only (not the generated DDS code or third-party sources in the build),
# and headers under the same folders: a path inside the build tree never matches.
mapfile -t files < <(python3 - "$build/compile_commands.json" "$root" "$components" "$only" <<'EOF'
import json, re, sys
database, root, components, only = sys.argv[1:5]
project = re.compile("^" + re.escape(root) + "/(" + components + ")/")
for entry in json.load(open(database)):
    path = entry["file"]
    if project.match(path) and (not only or re.search(only, path)):
        print("^" + re.escape(path) + "$")  # run-clang-tidy takes regular expressions
EOF
)
if [[ ${#files[@]} -eq 0 ]]; then
  echo "tidy: no project source in $build matches '${only}'" >&2
  exit 2
fi
echo "tidy: ${#files[@]} sources"
header_filter="^$(printf '%s' "$root" | sed 's/[.[\*^$()+?{|]/\\&/g')/($components)/"
log=$(mktemp)
trap 'rm -f "$log"' EXIT
# run-clang-tidy 14 has no -warnings-as-errors and exits 0 on warnings: count them here.
status=0
run-clang-tidy -p "$build" -j "$(nproc)" -quiet -header-filter="$header_filter" "${files[@]}" |
  tee "$log" || status=$?
# Only the project's own files: a system header's note (OpenCV's) is not ours to fix.
findings=$(sed 's/\x1b\[[0-9;]*m//g' "$log" | { grep -E ': (warning|error): ' || true; } |
  { grep -F "$root/" || true; } | sort -u | wc -l)
if ((findings > 0 || status != 0)); then
  echo "tidy: $findings findings (run-clang-tidy exit status $status)" >&2
  exit 1
fi
echo "tidy: clean"
