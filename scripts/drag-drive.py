#!/usr/bin/env python3
# Issue 18's drag without a browser: what the server alone delivers while a camera is dragged.
# Starts myriad-server, opens the web client's stream (a 1280x720 JPEG stream, quality 90, fps 30,
# interactive=24) on a new session of the built-in scene, and for each drag sends camera PATCHes
# at --rate a second for --seconds (the eye going round the target), then one more with
# X-Myriad-Interaction: end, as the page does on release. Prints JSON per drag: parts a second
# (and PATCHes a second), the median render scale of the parts, the server's CPU time per part
# (all its threads, llvmpipe's included: /proc/PID/stat), and the release-to-still time.
# Beside scripts/bench-page.sh, it tells the server's share of the page's figures from the
# browser's (Chromium on the same cores, its input and decoding). Not a test: it asserts nothing.
# Usage: scripts/drag-drive.py [myriad-server] [--seconds 5] [--rate 30] [--drags 2] [-- flags]
import argparse
import http.client
import json
import math
import os
import subprocess
import sys
import threading
import time

args = sys.argv[1:]
server_flags = args[args.index('--') + 1:] if '--' in args else []
if '--' in args:
    args = args[:args.index('--')]
parser = argparse.ArgumentParser()
parser.add_argument('server', nargs='?', default='build/release/server/myriad-server')
parser.add_argument('--seconds', type=float, default=5.0)
parser.add_argument('--rate', type=float, default=30.0)
parser.add_argument('--drags', type=int, default=2)
opts = parser.parse_args(args)

server = subprocess.Popen([opts.server, '--port', '0', *server_flags], stdout=subprocess.PIPE,
                          stderr=subprocess.DEVNULL, text=True)
try:
    port = None
    for line in server.stdout:
        if 'listening on' in line:
            port = int(line.strip().rsplit(':', 1)[1])
            break
    if port is None:
        sys.exit('drag-drive: the server did not start')

    def connect():
        return http.client.HTTPConnection('127.0.0.1', port, timeout=60)

    setup = connect()
    setup.request('POST', '/v1/sessions', body='{}', headers={'Content-Type': 'application/json'})
    created = json.loads(setup.getresponse().read())
    session = f"/v1/sessions/{created['id']}"
    auth = {'Authorization': 'Bearer ' + created['token'], 'Content-Type': 'application/json'}
    setup.request('GET', session + '/camera', headers=auth)
    camera = json.loads(setup.getresponse().read())

    parts = []  # (arrival, render scale or 0 for a full-quality part)

    def read_stream():
        stream = connect()
        stream.request('GET', session + '/stream?format=jpeg&width=1280&height=720&quality=90'
                       '&fps=30&interactive=24', headers=auth)
        body = stream.getresponse().fp
        while True:
            line = body.readline()
            if not line:
                return
            if line.lower().startswith(b'content-type: image'):
                headers = {}
                while (header := body.readline().strip()):
                    name, value = header.decode().split(':', 1)
                    headers[name.strip().lower()] = value.strip()
                body.read(int(headers['content-length']))
                parts.append((time.monotonic(), float(headers.get('x-myriad-interactive', 0))))

    threading.Thread(target=read_stream, daemon=True).start()
    while not parts:
        time.sleep(0.05)

    def cpu_seconds():
        fields = open(f'/proc/{server.pid}/stat').read().rsplit(')', 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')

    target = camera['target']
    offset = [camera['eye'][i] - target[i] for i in range(3)]
    radius = math.hypot(offset[0], offset[2])
    start_angle = math.atan2(offset[2], offset[0])
    patcher = connect()

    def patch(step, end=False):
        global patcher
        angle = start_angle + 0.02 * step
        eye = [target[0] + radius * math.cos(angle), camera['eye'][1],
               target[2] + radius * math.sin(angle)]
        headers = {**auth, 'X-Myriad-Interaction': 'end'} if end else auth
        for attempt in range(2):
            try:
                patcher.request('PATCH', session + '/camera', body=json.dumps({'eye': eye}),
                                headers=headers)
                patcher.getresponse().read()
                return
            except (http.client.HTTPException, OSError):
                patcher = connect()  # the kept-alive connection was closed while idle

    results = []
    step = 0
    for _ in range(opts.drags):
        time.sleep(1.5)  # the still of the step before has shown
        first_part = len(parts)
        cpu_before = cpu_seconds()
        began = time.monotonic()
        sent = 0
        while time.monotonic() - began < opts.seconds:
            step += 1
            sent += 1
            patch(step)
            time.sleep(max(0.0, began + sent / opts.rate - time.monotonic()))
        ended = time.monotonic()
        cpu_used = cpu_seconds() - cpu_before
        during = parts[first_part:]
        released = time.monotonic()
        step += 1
        patch(step, end=True)
        still = None
        while still is None and time.monotonic() - released < 30:
            still = next((t - released for t, scale in parts[first_part:]
                          if t > released and scale == 0), None)
            time.sleep(0.002)
        scales = sorted(scale for _, scale in during)
        results.append({
            'partsPerS': round(len(during) / (ended - began), 1),
            'patchesPerS': round(sent / (ended - began), 1),
            'scaleMedian': scales[len(scales) // 2] if scales else None,
            'cpuMsPerPart': round(1000 * cpu_used / max(1, len(during)), 1),
            'stillMs': round(1000 * still) if still is not None else None,
        })
    print(json.dumps({'loadAverage': open('/proc/loadavg').read().split()[:3], 'drags': results}))
finally:
    server.terminate()
    try:
        server.wait(timeout=30)
    except subprocess.TimeoutExpired:
        server.kill()
