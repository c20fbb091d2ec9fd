# shellcheck shell=bash disable=SC2154
# Shared by scripts/deploy_test.sh and scripts/deploy_boot_test.sh; sourced, not run.
# The caller is in the repository root and sets, before sourcing:
#   label   the name in progress lines ("deploy test")
#   root    the folder the clean Debian 12 root is unpacked into
# It gets: say, fail, require_root_and_debootstrap, build_package (sets deb), ensure_base
# (sets base: the cached Debian 12 minbase + systemd root tarball), unpack_root, in_root,
# unmount_root, cleanup_root, and work, suite, mirror.
start_s=$(date +%s)
work=build/deploy-test
suite=bookworm
base=$work/debian12-minbase-systemd.tar

say() { echo "== $label [$(($(date +%s) - start_s)) s]: $*"; }
fail() {
  echo "FAILED: $label: $*" >&2
  exit 1
}

require_root_and_debootstrap() {
  [[ $(id -u) -eq 0 ]] || fail "needs root (debootstrap, chroot and mounts)"
  command -v debootstrap >/dev/null || fail "debootstrap missing (bash scripts/setup.sh)"
  command -v dpkg-shlibdeps >/dev/null || fail "dpkg-shlibdeps missing (apt-get install dpkg-dev)"
}

# The mirror the host's apt uses (deb822 sources first, then sources.list); the root's apt
# uses the same one.
mirror=$(grep -hs -oE '^URIs: *[^ ]*/debian/?$' /etc/apt/sources.list.d/*.sources |
  sed -E 's/^URIs: *//' | head -1 || true)
[[ -n $mirror ]] || mirror=$(grep -hs -oE '^deb +[^ ]*/debian/? ' /etc/apt/sources.list |
  awk '{print $2}' | head -1 || true)
mirror=${mirror:-http://deb.debian.org/debian}
mirror=${mirror%/}

mkdir -p "$work/apt-archives/partial"

# build_package BUILD_DIR: configures BUILD_DIR for /usr, builds linectl, makes the .deb with
# cpack and sets deb to its path. With FL_DEB=path/fillet-line_*.deb set, uses that package
# instead and builds nothing (one package for both deployment tests).
build_package() {
  local build_dir=$1
  if [[ -n ${FL_DEB:-} ]]; then
    say "package $FL_DEB (FL_DEB: not built here)"
    [[ -f $FL_DEB ]] || fail "FL_DEB=$FL_DEB: no such file"
    deb=$FL_DEB
  else
    say "package (cpack DEB) from $build_dir"
    cmake -S . -B "$build_dir" -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
    cmake --build "$build_dir" --target linectl -j "${FL_BUILD_JOBS:-$(nproc)}"
    rm -rf "$build_dir/package"
    (cd "$build_dir" && cpack -G DEB -B package >/dev/null)
    deb=$(ls "$build_dir"/package/fillet-line_*.deb)
  fi
  dpkg-deb --field "$deb" Package Version Depends Recommends
  dpkg-deb --contents "$deb" | awk '{print "  " $6}'
}

# The clean Debian 12 root, debootstrap minbase plus systemd, made once and cached as $base.
ensure_base() {
  [[ -f $base ]] && return 0
  say "making the Debian 12 base root from $mirror (cached as $base)"
  rm -rf "$work/base-root"
  debootstrap --variant=minbase --include=systemd --cache-dir="$(realpath "$work/apt-archives")" \
    "$suite" "$work/base-root" "$mirror" >"$work/debootstrap.log" 2>&1 ||
    fail "debootstrap (log: $work/debootstrap.log)"
  cat >"$work/base-root/etc/apt/sources.list" <<EOF
deb $mirror $suite main
deb $mirror $suite-updates main
deb ${mirror}-security $suite-security main
EOF
  tar -C "$work/base-root" -cf "$base.partial" . && mv "$base.partial" "$base"
  rm -rf "$work/base-root"
}

# A fresh root from $base in $root, with /proc, apt's package cache bound to
# $work/apt-archives, the host's resolv.conf and the package in /tmp.
unpack_root() {
  say "clean root from $base"
  rm -rf "$root"
  mkdir -p "$root"
  tar -C "$root" -xf "$base"
  cp /etc/resolv.conf "$root/etc/resolv.conf"
  mount -t proc proc "$root/proc"
  mount --bind "$work/apt-archives" "$root/var/cache/apt/archives"
  cp "$deb" "$root/tmp/"
}

in_root() { chroot "$root" /usr/bin/env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 "$@"; }

unmount_root() {
  for mount_point in var/cache/apt/archives proc; do
    if mountpoint -q "$root/$mount_point" 2>/dev/null; then umount "$root/$mount_point"; fi
  done
}

cleanup_root() {
  unmount_root
  # Never delete through a mount that is still there (the package cache, /proc).
  if ! grep -q " $(realpath -m "$root")/" /proc/mounts; then rm -rf "$root"; fi
}
