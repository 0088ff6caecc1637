#!/usr/bin/env bash
# The live view's bandwidth, encode time, quality and latency (bench/history/
# performance-2026-11-to-12.md, "Stream bandwidth"): starts myriad-server on a free port, runs
# myriad-stream-bandwidth against it (JPEG, then VP8 and VP9 streams of one session with N
# animated lights) and prints the bench's JSON.
#
#   server/bench/stream_bandwidth.sh SERVER_COMMAND BENCH_COMMAND [bench options...]
#   e.g. server/bench/stream_bandwidth.sh build/release/server/myriad-server \
#          build/release/server/bench/myriad-stream-bandwidth --width 1280 --height 720 --fps 30
# Bench options: --width --height --fps --lights --seconds --jpeg-quality --codecs --bitrate
# --psnr-samples --latency-edits --viewers --json FILE (myriad-stream-bandwidth with no --url lists them).
# Needs nothing but the two binaries (no browser, no curl); exit status 0 only when every stream
# delivered frames, decoded, and showed every edit.
set -euo pipefail
server_cmd=$1
bench_cmd=$2
shift 2
log=$(mktemp /tmp/myriad-stream-bandwidth.XXXXXX)
$server_cmd --port 0 --max-resolution 4096 >"$log.out" 2>"$log" &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null || true; rm -f "$log" "$log.out"' EXIT
url=
for _ in $(seq 1 600); do
  url=$(sed -n 's/^Myriad listening on //p' "$log.out" 2>/dev/null || true)
  [[ -n "$url" ]] && break
  kill -0 $server 2>/dev/null || { cat "$log" >&2; echo "stream bench: the server exited" >&2; exit 1; }
  sleep 0.2
done
[[ -n "$url" ]] || { echo "stream bench: the server did not start" >&2; exit 1; }
head -3 "$log" >&2
$bench_cmd --url "$url" "$@"
