#!/bin/sh
# make_test_pki.sh OUTDIR: makes a complete TEST public-key infrastructure for the
# tetcollide DDS Security profile in OUTDIR (created if missing): an identity CA, a
# permissions CA, identity certificates and keys for the service and for clients, a
# "foreign" CA with a client certificate the others must reject, the governance
# document, one permissions document per identity (all S/MIME-signed by the permissions
# CA) and one Cyclone DDS security fragment per identity (cyclonedds-secure-<id>.xml,
# from cyclonedds-secure.xml beside this script). config/security/README.md describes
# every file. Keys are made fresh on every run and are never committed.
#
# Environment (all optional):
#   TC_PKI_DAYS                 validity of certificates and permissions, days (365)
#   TC_PKI_DOMAIN_MIN/MAX       DDS domain ids the governance and grants cover (0, 230;
#                               the access-control plugin rejects ids above 230)
#   TC_DDS_SECURITY_PLUGIN_DIR  directory of libdds_security_{auth,ac,crypto}.so
#                               (default: Debian's libddsc0debian directory)
# Exit status: 0 done, 1 failure (message on stderr), 2 usage.
set -eu

usage() { echo "usage: $0 OUTDIR" >&2; exit 2; }
[ $# -eq 1 ] || usage
[ -n "$1" ] || usage
OUT=$1
HERE=$(cd "$(dirname "$0")" && pwd)
DAYS=${TC_PKI_DAYS:-365}
DMIN=${TC_PKI_DOMAIN_MIN:-0}
DMAX=${TC_PKI_DOMAIN_MAX:-230}

command -v openssl >/dev/null 2>&1 || { echo "$0: openssl not found (apt-get install openssl)" >&2; exit 1; }

# The security plugins: Debian ships them outside the default library search path.
PLUGIN_DIR=${TC_DDS_SECURITY_PLUGIN_DIR:-}
if [ -z "$PLUGIN_DIR" ]; then
  for d in /usr/lib/*/libddsc0debian /usr/lib/libddsc0debian /usr/local/lib /usr/lib; do
    if [ -f "$d/libdds_security_auth.so" ]; then PLUGIN_DIR=$d; break; fi
  done
fi
for p in auth ac crypto; do
  [ -f "$PLUGIN_DIR/libdds_security_$p.so" ] || {
    echo "$0: libdds_security_$p.so not found in '${PLUGIN_DIR}' (set TC_DDS_SECURITY_PLUGIN_DIR)" >&2
    exit 1
  }
done

mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)
umask 077
cd "$OUT"

# Private key: ECDSA P-256 (the builtin PKI-DH plugin accepts RSA-2048 and P-256; P-256
# makes the authentication handshake cheaper).
key() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1.key" 2>/dev/null; }

# Self-signed CA certificate: ca NAME SUBJECT [EXTRA_KEY_USAGE]. The permissions CA signs
# the governance and permissions documents itself (S/MIME), so it also needs
# digitalSignature: the access-control plugin verifies the signer's purpose.
ca() {
  key "$1"
  openssl req -new -x509 -key "$1.key" -out "$1.pem" -days "$DAYS" -subj "$2" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,keyCertSign,cRLSign${3:-}"
}

# Identity certificate signed by a CA: identity NAME SUBJECT CA
identity() {
  key "$1"
  openssl req -new -key "$1.key" -subj "$2" -out "$1.csr"
  printf 'basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature,keyAgreement\n' >"$1.ext"
  openssl x509 -req -in "$1.csr" -CA "$3.pem" -CAkey "$3.key" -CAcreateserial \
    -CAserial "$3.srl" -days "$DAYS" -extfile "$1.ext" -out "$1.pem" 2>/dev/null
  rm -f "$1.csr" "$1.ext"
}

# Subject of a certificate in the RFC 2253 form the access-control plugin compares.
subject() { openssl x509 -noout -subject -nameopt RFC2253 -in "$1.pem" | sed 's/^subject= *//'; }

NOT_BEFORE=$(date -u -d '-1 hour' +%Y-%m-%dT%H:%M:%S)
NOT_AFTER=$(date -u -d "+$DAYS days" +%Y-%m-%dT%H:%M:%S)

# fill TEMPLATE OUTPUT [KEY=VALUE...]: replaces @KEY@ (values must not contain '|').
fill() {
  tpl=$1; dst=$2; shift 2
  script="s|@DOMAIN_MIN@|$DMIN|g;s|@DOMAIN_MAX@|$DMAX|g;s|@NOT_BEFORE@|$NOT_BEFORE|g;s|@NOT_AFTER@|$NOT_AFTER|g"
  for kv in "$@"; do script="$script;s|@${kv%%=*}@|${kv#*=}|g"; done
  sed "$script" "$HERE/$tpl" >"$dst"
  if grep -q '@[A-Z_]*@' "$dst"; then echo "$0: unfilled placeholder in $dst" >&2; exit 1; fi
}

# Signs an XML document with the permissions CA (S/MIME, clear text, signer included).
sign() { openssl smime -sign -text -in "$1.xml" -out "$1.p7s" -signer permissions_ca.pem -inkey permissions_ca.key; }

ca identity_ca "/O=tetcollide test/CN=tetcollide test identity CA"
ca permissions_ca "/O=tetcollide test/CN=tetcollide test permissions CA" ",digitalSignature"
ca foreign_ca "/O=foreign/CN=foreign identity CA"

identity service "/O=tetcollide test/CN=tetcollided" identity_ca
identity client "/O=tetcollide test/CN=client" identity_ca
identity client_noforces "/O=tetcollide test/CN=client-noforces" identity_ca
# Same subject as `client` but issued by the foreign CA: it can even present the genuine
# client permissions document, authentication must still fail.
identity foreign_client "/O=tetcollide test/CN=client" foreign_ca

fill governance.xml.in governance.xml
sign governance
fill permissions-service.xml.in permissions_service.xml "SUBJECT=$(subject service)"
fill permissions-client.xml.in permissions_client.xml "SUBJECT=$(subject client)" GRANT=client
fill permissions-client-noforces.xml.in permissions_client_noforces.xml \
  "SUBJECT=$(subject client_noforces)" GRANT=client_noforces
for p in service client client_noforces; do sign "permissions_$p"; done
cp permissions_client.xml permissions_foreign_client.xml
cp permissions_client.p7s permissions_foreign_client.p7s

for id in service client client_noforces; do
  fill cyclonedds-secure.xml "cyclonedds-secure-$id.xml" "PLUGIN_DIR=$PLUGIN_DIR" "PKI_DIR=$OUT" \
    IDENTITY=$id IDENTITY_CA=identity_ca
done
fill cyclonedds-secure.xml cyclonedds-secure-foreign_client.xml "PLUGIN_DIR=$PLUGIN_DIR" \
  "PKI_DIR=$OUT" IDENTITY=foreign_client IDENTITY_CA=foreign_ca

# Certificates, documents and profiles are public; keys stay readable by the owner only.
chmod 644 ./*.pem ./*.xml ./*.p7s
chmod 600 ./*.key
echo "test PKI in $OUT (valid $DAYS days, domains $DMIN..$DMAX, plugins in $PLUGIN_DIR)"
