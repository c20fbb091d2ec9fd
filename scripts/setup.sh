#!/usr/bin/env bash
# Installs every build and test dependency from Debian 12's packages. Idempotent: packages
# already present are left alone, so it is cheap to run before every build.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  clang clang-format clang-tidy libclang-rt-14-dev
  libeigen3-dev libspdlog-dev libfmt-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopencv-dev cyclonedds-dev cyclonedds-tools openssl
  rt-tests python3
  qemu-system-x86 busybox-static can-utils
  libzstd-dev liblz4-dev libdeflate-dev libnlopt-dev
  dpkg-dev debootstrap systemd
  libcivetweb-dev libssl-dev chromium
)

missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" ||
    missing+=("$package")
done

if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  as_root=()
  [[ $(id -u) -eq 0 ]] || as_root=(sudo)
  export DEBIAN_FRONTEND=noninteractive
  "${as_root[@]}" apt-get update -q
  "${as_root[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#packages[@]} packages present"
fi

# The MCAP interoperability test reads and writes files with the reference implementation
# (@mcap/core from the npm registry), pinned by vision/mcap/interop/package-lock.json.
# Node.js comes with the machine image here; Debian's own nodejs and npm are the fallback
# (not installed over an existing Node.js, whose bundled npm they would conflict with).
sudo_prefix=()
if ! command -v npm >/dev/null; then
  [[ $(id -u) -eq 0 ]] || sudo_prefix=(sudo)
  "${sudo_prefix[@]}" apt-get install -y -q --no-install-recommends nodejs npm
fi
here="$(cd "$(dirname "$0")/.." && pwd)"
if [[ ! -d "$here/vision/mcap/interop/node_modules/@mcap/core" ]]; then
  echo "setup: installing the MCAP interop test's node modules"
  npm ci --prefix "$here/vision/mcap/interop" --no-audit --no-fund --ignore-scripts
fi
# The HMI's end-to-end test drives Debian's chromium with playwright-core (no browser
# download), pinned by hmi/tests/e2e/package-lock.json.
if [[ ! -d "$here/hmi/tests/e2e/node_modules/playwright-core" ]]; then
  echo "setup: installing the HMI end-to-end test's node modules"
  npm ci --prefix "$here/hmi/tests/e2e" --no-audit --no-fund --ignore-scripts
fi
