#!/usr/bin/env bash
# A session with many animated lights, end to end through the HTTP API, as a user would drive it:
# start myriad-server, create a session, generate N lights, turn animation on, pick a technique,
# fetch frames and report each frame's Server-Timing (GPU passes, culling report) and, at the end,
# the validation message count. Not a benchmark (myriad-bench is): it checks that the service path
# renders a million moving lights without overflow, on whatever device the server picks.
#
#   server/bench/session_check.sh SERVER_COMMAND [LIGHTS] [WIDTHxHEIGHT] [FRAMES] [TECHNIQUE]
#   e.g. server/bench/session_check.sh "build/release/server/myriad-server --validate" 1000000 320x180 3
# On the GPU machine SERVER_COMMAND is "bash .devpack/run.sh .devpack/bin/myriad-server --validate".
# Optional environment: GENERATE (extra members of the lights/generate body, e.g.
# '"radius": [0.05, 0.3]'), SETTINGS (extra members of the settings PATCH, e.g. '"markers": false'),
# FORMAT (png, jpeg or raw; default png). Needs curl and python3. Exit status 0 only when every frame is 200, no light reference was dropped
# and the server reports 0 validation messages.
set -euo pipefail
server_cmd=$1
lights=${2:-1000000}
size=${3:-320x180}
frames=${4:-3}
technique=${5:-clustered}
width=${size%x*}
height=${size#*x}
log=$(mktemp /tmp/myriad-session-check.XXXXXX)
$server_cmd --port 0 --max-resolution 4096 >"$log.out" 2>"$log" &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null || true' EXIT
for _ in $(seq 1 600); do
  url=$(sed -n 's/^Myriad listening on //p' "$log.out" 2>/dev/null || true)
  [[ -n "$url" ]] && break
  kill -0 $server 2>/dev/null || { cat "$log"; echo "session check: the server exited"; exit 1; }
  sleep 0.2
done
[[ -n "$url" ]] || { echo "session check: the server did not start"; exit 1; }
head -3 "$log"
json() { python3 -c "import json,sys; d=json.load(sys.stdin); print(eval(sys.argv[1], {}, {'d': d}))" "$1"; }
created=$(curl -sf -X POST -H 'Content-Type: application/json' -d '{}' "$url/v1/sessions")
id=$(json 'd["id"]' <<<"$created")
token=$(json 'd["token"]' <<<"$created")
auth=(-H "Authorization: Bearer $token")
base="$url/v1/sessions/$id"
start=$(date +%s.%N)
curl -sf "${auth[@]}" -H 'Content-Type: application/json' \
  -d "{\"count\": $lights, \"seed\": 7${GENERATE:+, $GENERATE}}" "$base/lights/generate" >/dev/null
echo "generated $lights lights in $(python3 -c "print(round($(date +%s.%N) - $start, 2))") s"
curl -sf "${auth[@]}" -X PATCH -H 'Content-Type: application/json' \
  -d "{\"animate\": true, \"technique\": \"$technique\"${SETTINGS:+, $SETTINGS}}" "$base/settings" >/dev/null
status=0
for i in $(seq 1 "$frames"); do
  headers=$(curl -s -D - -o /tmp/myriad-session-frame -w '%{http_code} %{time_total}' "${auth[@]}" \
    "$base/frame?width=$width&height=$height&time=$i&format=${FORMAT:-png}")
  code=$(tail -1 <<<"$headers" | awk '{print $1}')
  timing=$(grep -i '^server-timing:' <<<"$headers" | tr -d '\r' || true)
  echo "frame $i: HTTP $code, wall $(tail -1 <<<"$headers" | awk '{print $2}') s"
  echo "  $timing"
  [[ "$code" == 200 ]] || status=1
  grep -q 'dropped 0 light references' <<<"$timing" || { echo "  (light references dropped, or no culling report)"; status=1; }
done
curl -sf "${auth[@]}" "$base/stats" | python3 -m json.tool | head -60
messages=$(curl -sf "$url/v1/info" | json 'd["validation"]["messages"]')
echo "validation messages: $messages"
[[ "$messages" == 0 ]] || status=1
curl -sf -X DELETE "${auth[@]}" "$base" -o /dev/null -w 'DELETE session: HTTP %{http_code}\n'
exit $status
