#!/usr/bin/env bash
# The container test: builds docker/Dockerfile and checks the image a user would run.
#
#   sudo tests/container/container_test.sh        # from anywhere; Debian 12, root
#   ctest --preset release -L container           # the same, as CI runs it (scripts/test.sh)
#
# Measured on 2 shared cores: cold (no image, no base image) 8 to 14 min, most of it compiling the
# server in the build stage and debootstrap; warm (layers cached, sources unchanged) under 40 s.
#
# Needs no Docker engine and no registry: the base image is bootstrapped from this machine's apt
# archive (scripts/container-base-image.sh), buildah builds the image and runs it with chroot
# isolation, which shares this machine's network. What it does mirrors, step by step:
#
#   docker build -t localhost/myriad -f docker/Dockerfile .
#   docker run --rm -p PORT:8080 localhost/myriad          # ENTRYPOINT + CMD of the image
#   curl localhost:PORT/v1/health; curl -o f.png 'localhost:PORT/v1/frame?width=320&height=180'
#   docker stop CONTAINER                                  # SIGTERM; must exit 0
#
# Checks: the image builds; its size (printed as "image size: N MB", and under a budget); no
# compiler, build tool or -dev package in it; it runs as a non-root user; its config (port,
# volume, stop signal, health check, entrypoint); the server started by the image's own
# ENTRYPOINT answers /v1/health from outside and the image's HEALTHCHECK command passes; the
# image's `myriad` CLI opens a session from inside; a
# 320x180 frame is a PNG of that size and not one flat colour; a frame in flight when SIGTERM
# arrives is still answered, and the server then exits 0 in time. Any failure: a line starting
# "container test: FAIL", non-zero exit. Idempotent: re-runs reuse the base image and buildah's
# layer cache; the working container is removed on exit, the image is kept.
#
# Environment: MYRIAD_IMAGE (default localhost/myriad), MYRIAD_IMAGE_BUDGET_MB (default 450),
# MYRIAD_START_TIMEOUT (s, default 120), MYRIAD_STOP_TIMEOUT (s, default 30).
set -euo pipefail

cd "$(dirname "$0")/../.."
image=${MYRIAD_IMAGE:-localhost/myriad}
budget_mb=${MYRIAD_IMAGE_BUDGET_MB:-450}
start_timeout=${MYRIAD_START_TIMEOUT:-120}
stop_timeout=${MYRIAD_STOP_TIMEOUT:-30}
work=$(mktemp -d /tmp/myriad-container-test.XXXXXX)
ctr=""
runner_pid=""   # the backgrounded `buildah run`
server_pid=""   # myriad-server itself, a descendant of it

fail() {
  echo "container test: FAIL: $*" >&2
  exit 1
}

cleanup() {
  local status=$?
  if [[ -n "$server_pid" ]] && kill -0 "$server_pid" 2>/dev/null; then
    kill -KILL "$server_pid" 2>/dev/null || true
  fi
  if [[ -n "$runner_pid" ]]; then
    kill -0 "$runner_pid" 2>/dev/null && kill -KILL "$runner_pid" 2>/dev/null
    wait "$runner_pid" 2>/dev/null || true
  fi
  if [[ -n "$ctr" ]]; then buildah rm "$ctr" >/dev/null 2>&1 || true; fi
  if [[ $status -ne 0 && -s "$work/server.log" ]]; then
    echo "--- server log (last 30 lines) ---" >&2
    tail -30 "$work/server.log" >&2
  fi
  rm -rf "$work"
  exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Timings: `step NAME` starts one, the next `step` (or `step_end`) closes it.
timings=()
step_name=""
step_start=""
now() { echo "${EPOCHREALTIME/,/.}"; }
step_end() {
  if [[ -n "$step_name" ]]; then
    local seconds
    seconds=$(awk -v a="$step_start" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
    timings+=("$(printf '%-28s %7s s' "$step_name" "$seconds")")
    echo "container test: $step_name: ${seconds} s"
  fi
  step_name=""
}
step() {
  step_end
  step_name=$1
  step_start=$(now)
  echo "container test: == $step_name"
}
test_start=$(now)

if [[ $(id -u) -ne 0 ]]; then
  # CTest reports exit status 77 as skipped (SKIP_RETURN_CODE in tests/CMakeLists.txt); CI runs as
  # root, so there a missing root is a failure, never a skip.
  [[ -z "${CI:-}" ]] || fail "run as root (debootstrap and buildah's chroot isolation need it)."
  echo "container test: SKIPPED: needs root (debootstrap and buildah's chroot isolation)"
  exit 77
fi

step "tools"
scripts/install-deps.sh --container-test
for tool in buildah podman debootstrap curl file python3; do
  command -v "$tool" >/dev/null || fail "$tool is missing after scripts/install-deps.sh --container-test."
done

step "base image"
scripts/container-base-image.sh

step "build image"
# --layers: cache each step, as docker build does, so a re-run only redoes what changed.
# --format docker: the OCI format has no HEALTHCHECK (buildah would drop it with a warning).
if ! buildah bud --isolation chroot --pull=never --layers --format docker \
    -t "$image" -f docker/Dockerfile . >"$work/build.log" 2>&1; then
  tail -40 "$work/build.log" >&2
  fail "buildah bud failed (build log above)."
fi

step "image size and config"
podman image inspect "$image" >"$work/inspect.json" || fail "cannot inspect $image."
size_bytes=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))[0]["Size"])' "$work/inspect.json")
size_mb=$(( (size_bytes + 500000) / 1000000 ))
echo "image size: ${size_mb} MB"
(( size_mb <= budget_mb )) ||
  fail "the image is ${size_mb} MB, over its ${budget_mb} MB budget (MYRIAD_IMAGE_BUDGET_MB)."
# The config a `docker run` of this image gets; prints the entrypoint, one argument a line.
python3 - "$work/inspect.json" >"$work/entrypoint" <<'EOF' || fail "image config: see above."
import json, sys
image = json.load(open(sys.argv[1]))[0]
config = image.get("Config") or {}
problems = []
user = (config.get("User") or "").split(":")[0]
if user in ("", "0", "root"):
    problems.append(f"runs as root (User is {config.get('User')!r}); it must name an unprivileged user")
if "8080/tcp" not in (config.get("ExposedPorts") or {}):
    problems.append("does not EXPOSE 8080")
if "/models" not in (config.get("Volumes") or {}):
    problems.append("has no /models volume")
if config.get("StopSignal") not in ("SIGTERM", "15"):
    problems.append(f"StopSignal is {config.get('StopSignal')!r}, not SIGTERM")
health = image.get("HealthCheck") or image.get("Healthcheck") or config.get("Healthcheck") or {}
if not health.get("Test") or "/v1/health" not in " ".join(health["Test"]):
    problems.append("has no HEALTHCHECK asking /v1/health")
entrypoint = config.get("Entrypoint") or []
command = entrypoint + (config.get("Cmd") or [])
if not command or command[0] != "myriad-server" or "0.0.0.0" not in command:
    problems.append(f"ENTRYPOINT/CMD {command} does not start myriad-server on 0.0.0.0")
for p in problems:
    print(f"container test: the image {p}", file=sys.stderr)
if problems:
    sys.exit(1)
print(f"container test: user {config['User']}, entrypoint {command}, healthcheck {health['Test']}",
      file=sys.stderr)
for arg in command:
    print(arg)
# The health check's argv (CMD or CMD-SHELL form), NUL-separated, for the health check step.
test = health["Test"]
argv = test[1:] if test[0] == "CMD" else ["/bin/sh", "-c", test[1]]
with open(sys.argv[1] + ".health", "w") as f:
    f.write("\0".join(argv) + "\0")
EOF
mapfile -t entrypoint <"$work/entrypoint"

step "image contents"
ctr=$(buildah from --pull=never "$image")
uid=$(buildah run --isolation chroot "$ctr" -- id -u)
[[ "$uid" != 0 ]] || fail "a command in the container runs as root."
echo "container test: runs as $(buildah run --isolation chroot "$ctr" -- id -un) (uid $uid)"
buildah run --isolation chroot "$ctr" -- dpkg-query -W -f '${Package}\n' >"$work/packages"
echo "container test: $(wc -l <"$work/packages") packages"
forbidden=$(grep -E -e '-dev$' -e '^(gcc|g\+\+|cpp|clang|llvm|binutils|cmake|make|build-essential|pkg-config|pkgconf|glslang-tools)(-[0-9.]+)?$' \
  "$work/packages" || true)
[[ -z "$forbidden" ]] || fail "the runtime image has build packages: $(echo $forbidden)."
tools=$(buildah run --isolation chroot "$ctr" -- bash -c \
  'for t in cc c++ gcc g++ clang ld as cmake make glslangValidator; do command -v $t || true; done')
[[ -z "$tools" ]] || fail "the runtime image has build tools: $(echo $tools)."

step "start server"
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
# The image's own entrypoint, plus `--port` as `docker run IMAGE --port N` would append it (the last
# value wins); chroot isolation shares this machine's network, so 8080 could be taken here.
echo "container test: ${entrypoint[*]} --port $port"
buildah run --isolation chroot "$ctr" -- "${entrypoint[@]}" --port "$port" >"$work/server.log" 2>&1 &
runner_pid=$!
deadline=$((SECONDS + start_timeout))
until curl -fsS --max-time 5 -o "$work/health.json" "http://127.0.0.1:$port/v1/health" 2>/dev/null; do
  kill -0 "$runner_pid" 2>/dev/null || { wait "$runner_pid" && rc=0 || rc=$?;
    fail "the server exited (status $rc) before answering /v1/health."; }
  (( SECONDS < deadline )) || fail "no answer from /v1/health on port $port within ${start_timeout} s."
  sleep 0.5
done
grep -q '"status" *: *"ok"' "$work/health.json" || fail "/v1/health answered $(cat "$work/health.json")."
grep -q "Myriad listening on http://0.0.0.0:$port" "$work/server.log" ||
  fail "the server did not print \"Myriad listening on http://0.0.0.0:$port\"."
# myriad-server's own pid, to signal it as `docker stop` would: a descendant of the buildah run.
descendants() {
  local child
  for child in $(cat /proc/"$1"/task/*/children 2>/dev/null); do
    echo "$child"
    descendants "$child"
  done
}
for pid in $(descendants "$runner_pid"); do
  [[ "$(cat /proc/"$pid"/comm 2>/dev/null)" == myriad-server ]] && server_pid=$pid
done
[[ -n "$server_pid" ]] || fail "cannot find the myriad-server process under buildah run ($runner_pid)."
grep 'rendering on' "$work/server.log" | sed 's/^/container test: /' || true

step "health check"
# The image's HEALTHCHECK command, run inside the container as the engine would, on our port.
mapfile -d '' -t health <"$work/inspect.json.health"
health=("${health[@]//\/8080/\/$port}")
buildah run --isolation chroot "$ctr" -- "${health[@]}" ||
  fail "the image's HEALTHCHECK command failed against a running server."

step "cli"
# The image's `myriad` CLI talks to the server from inside the container (docker exec ... myriad).
session=$(buildah run --isolation chroot "$ctr" -- myriad --server "http://127.0.0.1:$port" \
  --session-file /tmp/myriad-session session new 2>&1) || fail "myriad session new in the image failed: $session"
echo "container test: cli: $session"

step "frame"
code=$(curl -sS --max-time 120 -o "$work/frame.png" -w '%{http_code} %{content_type}' \
  "http://127.0.0.1:$port/v1/frame?width=320&height=180") || fail "GET /v1/frame failed: curl error."
[[ "$code" == "200 image/png"* ]] || fail "GET /v1/frame answered \"$code\": $(head -c 300 "$work/frame.png")."
described=$(file -b "$work/frame.png")
echo "container test: frame: $described"
[[ "$described" == "PNG image data, 320 x 180,"* ]] || fail "the frame is not a 320x180 PNG: $described."
python3 - "$work/frame.png" <<'EOF' || fail "the frame is not a rendered image (see above)."
# Decode the PNG (8-bit greyscale/RGB/RGBA, not interlaced: what the server writes) and count colours.
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
pos, idat, header = 8, b"", None
while pos < len(data):
    length, kind = struct.unpack(">I4s", data[pos:pos + 8])
    chunk = data[pos + 8:pos + 8 + length]
    if kind == b"IHDR": header = struct.unpack(">IIBBBBB", chunk)
    if kind == b"IDAT": idat += chunk
    pos += 12 + length
width, height, depth, colour, _, _, interlace = header
channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour)
if depth != 8 or channels is None or interlace:
    sys.exit(f"container test: unexpected PNG format (depth {depth}, colour type {colour}, interlace {interlace})")
raw, stride = zlib.decompress(idat), width * channels
rows, prev = [], bytearray(stride)
for y in range(height):
    kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - channels] if i >= channels else 0
        b, c = prev[i], prev[i - channels] if i >= channels else 0
        if kind == 1: line[i] = (line[i] + a) & 255
        elif kind == 2: line[i] = (line[i] + b) & 255
        elif kind == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif kind == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    rows.append(bytes(line)); prev = line
pixels = {row[i:i + channels] for row in rows for i in range(0, stride, channels)}
luma = [sum(row[i:i + min(channels, 3)]) for row in rows for i in range(0, stride, channels)]
print(f"container test: frame has {len(pixels)} distinct colours, brightness {min(luma)}..{max(luma)}")
if len(pixels) < 16:
    sys.exit(f"container test: the frame has only {len(pixels)} colours: not a rendered scene")
EOF

step "SIGTERM"
# A frame still rendering when SIGTERM arrives must be answered, then the server exits 0.
curl -sS --max-time 120 -o "$work/inflight.png" -w '%{http_code}' \
  "http://127.0.0.1:$port/v1/frame?width=1920&height=1080" >"$work/inflight.code" 2>"$work/inflight.err" &
inflight_pid=$!
# Signal once the server has accepted that connection (a socket of its own, established, on the
# port): a connection still in the listen backlog would be reset by the stop, not served. Bash and
# one awk, no interpreter start-up: on a loaded 2-core machine python3 alone takes over a second,
# longer than some frames.
accepted() {
  local sockets
  sockets=$(ls -l "/proc/$server_pid/fd" 2>/dev/null | sed -n 's/.*socket:\[\([0-9]*\)\]$/\1/p')
  awk -v port="$(printf '%04X' "$port")" -v sockets="$sockets" '
    BEGIN { n = split(sockets, list, "\n"); for (i = 1; i <= n; i++) owned[list[i]] = 1 }
    FNR > 1 && $4 == "01" && toupper($2) ~ (":" port "$") && ($10 in owned) { found = 1 }
    END { exit !found }' /proc/net/tcp /proc/net/tcp6
}
deadline=$((SECONDS + 10))
until accepted; do
  (( SECONDS < deadline )) || fail "the server did not accept the frame request within 10 s."
  kill -0 "$inflight_pid" 2>/dev/null ||
    fail "the frame request ended before the server was seen accepting it: $(cat "$work/inflight.err")."
  sleep 0.02
done
kill -0 "$inflight_pid" 2>/dev/null ||
  fail "the frame was answered before SIGTERM (too quick to test stopping with a frame in flight)."
kill -TERM "$server_pid"
deadline=$((SECONDS + stop_timeout))
while kill -0 "$runner_pid" 2>/dev/null; do
  (( SECONDS < deadline )) || fail "the server was still running ${stop_timeout} s after SIGTERM."
  sleep 0.2
done
wait "$runner_pid" && rc=0 || rc=$?
runner_pid=""
server_pid=""
[[ $rc -eq 0 ]] || fail "the server exited with status $rc after SIGTERM, not 0."
wait "$inflight_pid" || true
[[ "$(cat "$work/inflight.code")" == 200 ]] ||
  fail "the frame in flight at SIGTERM was not answered: HTTP $(cat "$work/inflight.code") $(cat "$work/inflight.err")."
tail -2 "$work/server.log" | sed 's/^/container test: server: /'
# And the health check must notice: a check that passes with no server checks nothing.
if buildah run --isolation chroot "$ctr" -- "${health[@]}" >/dev/null 2>&1; then
  fail "the image's HEALTHCHECK command passes with the server stopped."
fi

step_end
echo "container test: timings"
printf '  %s\n' "${timings[@]}"
total=$(awk -v a="$test_start" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }')
echo "container test: PASS (image $image, ${size_mb} MB, ${total} s)"
