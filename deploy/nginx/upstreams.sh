#!/bin/sh
# Writes the nginx upstreams of a Myriad cluster (the file deploy/nginx/myriad.conf includes as
# myriad/upstreams.conf) for the nodes given as NODE_ID=HOST:PORT, each server started with
# --node-id NODE_ID (0-255) and one state store (--state-dir on one machine, --state-store
# postgresql://... on many):
#
#   deploy/nginx/upstreams.sh 0=10.0.0.10:8080 1=10.0.0.11:8080 2=10.0.0.12:8080 > upstreams.conf
#
# myriad_node_N   one node: the requests of the sessions whose id names node N (s-NN...)
# myriad_any      every node, least connections first: new sessions, /v1/frame, /v1/info, ...
# myriad_failover every node, consistent hash of the session id: where a session goes while its
#                 node does not answer (the same survivor for all its requests; it restores the
#                 session from the store once its lease on the dead node lapses)
# (keepalive_timeout 1 s: below the server's own 2 s, so nginx never reuses a connection the
# server is closing.)
# $myriad_home    the upstream of a session path's node (from $myriad_node, set in myriad.conf)
set -eu
if [ "$#" -eq 0 ]; then
  echo "usage: $0 NODE_ID=HOST:PORT ..." >&2
  exit 2
fi
hexes=""
for node in "$@"; do
  id=${node%%=*}
  address=${node#*=}
  case "$id" in
    '' | *[!0-9]*) echo "upstreams.sh: \"$node\" is not NODE_ID=HOST:PORT" >&2; exit 2 ;;
  esac
  if [ "$id" -gt 255 ] || [ "$address" = "$node" ] || [ -z "$address" ]; then
    echo "upstreams.sh: \"$node\" is not NODE_ID=HOST:PORT with NODE_ID 0-255" >&2
    exit 2
  fi
  hex=$(printf '%02x' "$id")
  case " $hexes " in *" $hex "*) echo "upstreams.sh: node $id given twice" >&2; exit 2 ;; esac
  hexes="$hexes $hex"
  # One server: nginx never marks it down, so each request tries it (a refused connection costs
  # little; proxy_connect_timeout bounds a host that does not answer) before the failover.
  printf 'upstream myriad_node_%s {\n  server %s;\n  keepalive 8;\n  keepalive_timeout 1s;\n}\n' "$id" "$address"
done
printf 'upstream myriad_any {\n  least_conn;\n'
for node in "$@"; do printf '  server %s max_fails=1 fail_timeout=10s;\n' "${node#*=}"; done
printf '  keepalive 16;\n  keepalive_timeout 1s;\n}\n'
printf 'upstream myriad_failover {\n  hash $myriad_session consistent;\n'
for node in "$@"; do printf '  server %s max_fails=1 fail_timeout=10s;\n' "${node#*=}"; done
printf '  keepalive 16;\n  keepalive_timeout 1s;\n}\n'
printf 'map $myriad_node $myriad_home {\n'
for node in "$@"; do
  id=${node%%=*}
  printf '  %s myriad_node_%s;\n' "$(printf '%02x' "$id")" "$id"
done
printf '  default myriad_failover;\n}\n'
