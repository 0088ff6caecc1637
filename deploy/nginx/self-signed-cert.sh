#!/bin/sh
# Makes a self-signed TLS certificate for the front (tests, a first look): DIR/tls.crt and
# DIR/tls.key, EC P-256, valid DAYS days (default 30) for localhost, 127.0.0.1 and NAMES.
#
#   deploy/nginx/self-signed-cert.sh docker/tls                 # localhost only
#   deploy/nginx/self-signed-cert.sh docker/tls 30 myriad.example.org
#
# Browsers warn about it; for a real deployment use a certificate from your CA or ACME (certbot,
# cert-manager on Kubernetes) with the same two file names.
set -eu
if [ "$#" -lt 1 ]; then
  echo "usage: $0 DIR [DAYS] [NAME ...]" >&2
  exit 2
fi
dir=$1
days=${2:-30}
[ "$#" -ge 2 ] && shift 2 || shift 1
names="DNS:localhost,IP:127.0.0.1"
for name in "$@"; do names="$names,DNS:$name"; done
mkdir -p "$dir"
umask 077
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days "$days" \
  -subj "/CN=${1:-localhost}" -addext "subjectAltName=$names" \
  -keyout "$dir/tls.key" -out "$dir/tls.crt" 2>/dev/null
chmod 644 "$dir/tls.crt"
echo "$dir/tls.crt and $dir/tls.key: self-signed for $names, $days days"
