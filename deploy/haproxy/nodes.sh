#!/bin/sh
# Writes the nodes' part of the HAProxy front (deploy/haproxy/myriad.cfg): the DNS resolvers and the
# three backends, for the nodes given as NODE_ID=NAME:PORT, each server started with
# --node-id NODE_ID (0-255) and one state store (--state-dir on one machine, --state-store
# postgresql://... on many). NAME is a DNS name (or an address), resolved again every second:
#
#   deploy/haproxy/nodes.sh 0=myriad-0.myriad-nodes:8080 1=myriad-1.myriad-nodes:8080 > nodes.cfg
#   deploy/haproxy/nodes.sh --resolver 10.0.0.2:53 0=node0.example:8080 ...
#
# The resolvers are those of /etc/resolv.conf unless --resolver ADDRESS:PORT names them (once
# each). Every front of a cluster must be given the same nodes in the same order: their server ids,
# which the consistent hash is built from, are the node ids, so that fronts agree without talking.
#
# myriad_sessions  /v1/sessions/{id}/...: the node the id names (s-NN...) while it is up, else one
#                  survivor by a consistent hash of the id over the live nodes (/v1/health)
# myriad_new       POST /v1/sessions: the least busy node that is ready (/v1/ready: 503 when full
#                  or draining), so a full node takes no new session but keeps serving its own
# myriad_any       everything else: the least busy live node
set -eu
usage() {
  echo "usage: $0 [--resolver ADDRESS:PORT]... NODE_ID=NAME:PORT ..." >&2
  exit 2
}
resolvers=""
while [ "$#" -gt 0 ]; do
  case "$1" in
    --resolver)
      [ "$#" -ge 2 ] || usage
      resolvers="$resolvers $2"
      shift 2
      ;;
    --resolver=*) resolvers="$resolvers ${1#--resolver=}"; shift ;;
    -*) usage ;;
    *) break ;;
  esac
done
[ "$#" -gt 0 ] || usage
ids=""
for node in "$@"; do
  id=${node%%=*}
  address=${node#*=}
  case "$id" in
    '' | *[!0-9]*) echo "nodes.sh: \"$node\" is not NODE_ID=NAME:PORT" >&2; exit 2 ;;
  esac
  port=${address##*:}
  case "$port" in
    '' | *[!0-9]*) echo "nodes.sh: \"$node\" is not NODE_ID=NAME:PORT" >&2; exit 2 ;;
  esac
  if [ "$id" -gt 255 ] || [ "$address" = "$node" ] || [ "$address" = "$port" ] ||
     [ "${address%:*}" = "" ]; then
    echo "nodes.sh: \"$node\" is not NODE_ID=NAME:PORT with NODE_ID 0-255" >&2
    exit 2
  fi
  case " $ids " in *" $id "*) echo "nodes.sh: node $id given twice" >&2; exit 2 ;; esac
  ids="$ids $id"
done

# Names resolved every second (timeout resolve), an answer kept 1 s (hold valid): a node that comes
# back on a new address is routed to within about 2 s plus its health checks (rise); an address no
# longer in the answer is dropped at once (hold obsolete 0s: HAProxy keeps a server on its old
# address while that is held, which delayed a move by the hold's 10 s in a test). A name that
# is gone (NXDOMAIN: the pod was deleted) keeps its last address for 10 s, then the server is put
# in maintenance until the name resolves again; a DNS server that does not answer changes nothing
# for 5 minutes. init-addr none (below) lets the front start before a name resolves (a pod still
# Pending).
echo 'resolvers myriad_dns'
if [ -n "$resolvers" ]; then
  n=0
  for r in $resolvers; do
    printf '  nameserver dns%d %s\n' "$n" "$r"
    n=$((n + 1))
  done
else
  echo '  parse-resolv-conf'
fi
cat <<'CFG'
  accepted_payload_size 8192
  resolve_retries 3
  timeout resolve 1s
  timeout retry 1s
  hold valid 1s
  hold obsolete 0s
  hold nx 10s
  hold other 30s
  hold refused 300s
  hold timeout 300s

# Health checks every 250 ms. A crashed node refuses the check's connection: down after 2 failed
# checks, the second 250 ms after the first (fastinter), so within 0.5 s, well inside the lease
# (--lease-ms 1000) a survivor waits out before it restores the node's sessions; on a loaded
# machine HAProxy's timers run late, and with checks every 500 ms the detection alone took up to
# 1.3 s. A hung node (SIGSTOPped, swapped out, deadlocked: its socket still accepts) fails a check
# after `timeout check` (1 s, myriad.cfg): down within 0.25 + 1 + 0.25 + 1 = 2.5 s. The requests
# still open on a node when it goes down are cut then (on-marked-down), so that none waits
# `timeout server` on a hung node.
# A node that is down is checked every 250 ms too (downinter) and is back after 2 good checks,
# 250 ms apart: within 0.5 s of answering again. Quickly, because a node taken for dead may still
# hold its sessions' leases (a hung node continued just after its checks failed renews them):
# until the fronts route to it again, a survivor asked for one of its sessions waits out the lease
# and answers 409 (with downinter 1 s such a hang's gap was 4.6-5.9 s in scripts/chaos.py); and
# two fronts disagree about a node that came back for up to one interval, a survivor answering
# 409 to one front while the node serves the other. 48 checks a second for 3 nodes and 2 fronts,
# answered by the nodes on workers of their own (so a busy node is not taken for a hung one).
# (Not `observe layer4`: marking a node down on a request's refused connection cuts that very
# request while it is being sent to another node.)
CFG
server_options='resolvers myriad_dns resolve-prefer ipv4 init-addr last,libc,none'
check_options='check inter 250ms fastinter 250ms downinter 250ms fall 2 rise 2 on-marked-down shutdown-sessions'

cat <<'CFG'

# A session's requests. Its home (the node its id names) while that node is up; else the
# consistent hash of the id over the live nodes, the same survivor for all its requests and on
# every front (the ring is built from the server ids, which are the node ids). The survivor waits
# for the home node's lease on the session to lapse (--lease-ms) and restores it from the store;
# when the home node is back, the session goes home (the survivor hands it over). Live, not ready:
# a full node keeps serving its sessions, and a full survivor answers 429 naming maxSessions for a
# session it cannot restore. A node that is not the session's owner answers 409 with
# X-Myriad-Owner: N; HAProxy passes it to the client (it cannot resend a request on a response
# status): it happens only while fronts see a node differently (a health check's interval, a name
# not resolved yet), and the client asks again (docs/deploy.md).
backend myriad_sessions
  balance hash path,field(4,/)
  hash-type consistent
  option httpchk
  http-check send meth GET uri /v1/health
  http-check expect status 200
  # A refused connection is a 503 at once (Retry-After: 1; the client asks again), not sent to
  # another node: a redispatch picks the node after the dead one on the ring, which for some ids
  # is not the node the ring without it gives (3 of 60 sessions in a test), so a session restored
  # there by its first request was then asked elsewhere and answered 409 until its copy expired.
  # Once the checks take the node off the ring (0.75 s), every request and every front agree.
  retries 0
  no option redispatch
  # Streams: each part is passed on as it arrives (HAProxy does not buffer responses). HAProxy's
  # timeouts are idle times and a stream re-sends its last image every 2 s, so 300 s would do;
  # an hour, so that a stream is never cut by a change of that re-send.
  acl myriad_stream path_reg ^/v1/sessions/[^/]+/stream$
  http-request set-timeout server 3600s if myriad_stream
CFG
for node in "$@"; do
  id=${node%%=*}
  printf '  use-server node%s if { path_beg /v1/sessions/s-%02x }\n' "$id" "$id"
done
for node in "$@"; do
  printf '  server node%s %s id %d %s %s\n' "${node%%=*}" "${node#*=}" "$((${node%%=*} + 1))" \
    "$server_options" "$check_options"
done

cat <<'CFG'

# New sessions: the least busy node that takes them (/v1/ready). Refused connections go to another
# node (a POST that never reached a node is safe to send again).
backend myriad_new
  balance leastconn
  option httpchk
  http-check send meth GET uri /v1/ready
  http-check expect status 200
  retries 2
  option redispatch 1
  retry-on conn-failure
CFG
for node in "$@"; do
  printf '  server node%s %s id %d %s %s\n' "${node%%=*}" "${node#*=}" "$((${node%%=*} + 1))" \
    "$server_options" "$check_options"
done

cat <<'CFG'

# Everything else (/v1/frame, /v1/info, /metrics, /v1/health, the web client): the least busy live
# node, as myriad_sessions sees them (track: one health check per node and front, not two).
backend myriad_any
  balance leastconn
  retries 2
  option redispatch 1
  retry-on conn-failure
CFG
for node in "$@"; do
  printf '  server node%s %s id %d %s track myriad_sessions/node%s\n' "${node%%=*}" "${node#*=}" \
    "$((${node%%=*} + 1))" "$server_options" "${node%%=*}"
done
