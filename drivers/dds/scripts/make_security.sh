#!/usr/bin/env bash
# Generates a DDS Security setup for the line into OUT_DIR: a CA (identity and permissions
# CA in one), one identity certificate and key per role (camera, controller, twin, hmi), the
# signed governance and permissions documents of config/dds/, and one Cyclone security
# configuration per role (cyclonedds-security-<role>.xml) from config/dds/cyclonedds-security.xml.in,
# to be given after a network configuration:
#   CYCLONEDDS_URI=file://$PWD/config/dds/cyclonedds-loopback.xml,file://OUT_DIR/cyclonedds-security-camera.xml
# --test-intruder adds the tests'
# "intruder" identity and its grant (drivers/dds/tests/intruder_grant.xml, hmi/ topics only).
# Adapted from ../shared/recipes/dds/sec-gen.sh. For tests and development: on a plant the
# CA key lives offline and each node gets only its own key.
#
#   make_security.sh OUT_DIR [--test-intruder]
# Exit 77 (the test runner's "skipped") when openssl or the security plugins are missing.
set -euo pipefail

out_dir=${1:?usage: make_security.sh OUT_DIR [--test-intruder]}
script_dir=$(cd "$(dirname "$0")" && pwd)
roles=(camera controller twin hmi)
extra_grants=
case "${2:-}" in
  "") ;;
  --test-intruder)
    roles+=(intruder)
    extra_grants=$script_dir/../tests/intruder_grant.xml
    ;;
  *)
    echo "make_security.sh: unknown option '$2' (only --test-intruder)" >&2
    exit 2
    ;;
esac
config_dir=$(cd "$script_dir/../../../config/dds" && pwd)
plugin_dir=${FL_DDS_SECURITY_PLUGIN_DIR:-/usr/lib/x86_64-linux-gnu/libddsc0debian}

if ! command -v openssl >/dev/null; then
  echo "make_security.sh: openssl not found (Debian package: openssl)" >&2
  exit 77
fi
for plugin in auth ac crypto; do
  if [[ ! -f "$plugin_dir/libdds_security_$plugin.so" ]]; then
    echo "make_security.sh: $plugin_dir/libdds_security_$plugin.so missing (libddsc0debian)" >&2
    exit 77
  fi
done

mkdir -p "$out_dir"
out_dir=$(cd "$out_dir" && pwd)  # the configurations name files by absolute path
cd "$out_dir"
# P-256 keys: what Cyclone's authentication plugin supports besides RSA-2048, and fast.
openssl ecparam -name prime256v1 -genkey -noout -out ca_key.pem
openssl req -x509 -new -key ca_key.pem -sha256 -days 3650 \
  -subj "/C=NL/O=FilletLine/CN=FilletLineCA" -out ca_cert.pem
for role in "${roles[@]}"; do
  openssl ecparam -name prime256v1 -genkey -noout -out "${role}_key.pem"
  openssl req -new -key "${role}_key.pem" -subj "/C=NL/O=FilletLine/CN=$role" -out "$role.csr"
  openssl x509 -req -in "$role.csr" -CA ca_cert.pem -CAkey ca_key.pem -CAcreateserial \
    -days 3650 -sha256 -out "${role}_cert.pem" 2>/dev/null
  sed -e "s|@SECURITY_DIR@|$out_dir|g" -e "s|@IDENTITY@|$role|g" -e "s|@PLUGIN_DIR@|$plugin_dir|g" \
    "$config_dir/cyclonedds-security.xml.in" >"cyclonedds-security-$role.xml"
done
openssl smime -sign -in "$config_dir/governance.xml" -text -out governance.p7s \
  -signer ca_cert.pem -inkey ca_key.pem
# The shipped grants, and the tests' own before the end of the list.
if [[ -n $extra_grants ]]; then
  awk -v grants="$extra_grants" '
    /<\/permissions>/ { while ((getline line < grants) > 0) print line }
    { print }' "$config_dir/permissions.xml" >permissions.xml
else
  cp "$config_dir/permissions.xml" permissions.xml
fi
openssl smime -sign -in permissions.xml -text -out permissions.p7s \
  -signer ca_cert.pem -inkey ca_key.pem
echo "make_security.sh: wrote CA, identities (${roles[*]}) to $out_dir"
