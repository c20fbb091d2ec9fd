#!/usr/bin/env bash
# Generates a DDS Security setup for the line into OUT_DIR: a CA (identity and permissions
# CA in one), one identity certificate and key per role (camera, controller, twin, hmi,
# intruder), the signed governance and permissions documents of config/dds/, and one
# Cyclone configuration per role (cyclonedds-<role>.xml) from the secure template.
# Adapted from ../shared/recipes/dds/sec-gen.sh. For tests and development: on a plant the
# CA key lives offline and each node gets only its own key.
#
#   make_security.sh OUT_DIR
# Exit 77 (the test runner's "skipped") when openssl or the security plugins are missing.
set -euo pipefail

out_dir=${1:?usage: make_security.sh OUT_DIR}
script_dir=$(cd "$(dirname "$0")" && pwd)
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
cd "$out_dir"
# P-256 keys: what Cyclone's authentication plugin supports besides RSA-2048, and fast.
openssl ecparam -name prime256v1 -genkey -noout -out ca_key.pem
openssl req -x509 -new -key ca_key.pem -sha256 -days 3650 \
  -subj "/C=NL/O=FilletLine/CN=FilletLineCA" -out ca_cert.pem
for role in camera controller twin hmi intruder; do
  openssl ecparam -name prime256v1 -genkey -noout -out "${role}_key.pem"
  openssl req -new -key "${role}_key.pem" -subj "/C=NL/O=FilletLine/CN=$role" -out "$role.csr"
  openssl x509 -req -in "$role.csr" -CA ca_cert.pem -CAkey ca_key.pem -CAcreateserial \
    -days 3650 -sha256 -out "${role}_cert.pem" 2>/dev/null
  sed -e "s|@SEC_DIR@|$out_dir|g" -e "s|@IDENTITY@|$role|g" -e "s|@PLUGIN_DIR@|$plugin_dir|g" \
    "$config_dir/cyclonedds-loopback-secure.xml.in" >"cyclonedds-$role.xml"
done
openssl smime -sign -in "$config_dir/governance.xml" -text -out governance.p7s \
  -signer ca_cert.pem -inkey ca_key.pem
openssl smime -sign -in "$config_dir/permissions.xml" -text -out permissions.p7s \
  -signer ca_cert.pem -inkey ca_key.pem
echo "make_security.sh: wrote CA, identities (camera controller twin hmi intruder) to $out_dir"
