#!/usr/bin/env python3
"""Frames a second of Session.render_path through the Python client, per concurrency.

Starts its own myriad-server (--server PATH, --port 0) or uses a running one (--url), makes a
session of the built-in scene with --lights generated lights, and renders --frames frames of an
orbit at --size with the --targets, once per --concurrency value; prints one line per run and a
JSON summary. Frames are decoded to numpy arrays (as a user gets them) and then dropped.

    python3 client/python/examples/bench_render_path.py \
        --server build/release/server/myriad-server --lights 100000 --size 1280x720 \
        --frames 1000 --concurrency 1,2,4,8 --json results.json

On the GPU machine (../shared/device/README.md): pack the server here with
``../shared/device/pack.sh build/release/server/myriad-server``, carry ``.devpack`` and run
``bash .devpack/run.sh env PYTHONPATH=client/python python3 client/python/examples/bench_render_path.py
--server .devpack/bin/myriad-server --lights 100000 --size 1280x720 --frames 1000
--concurrency 1,2,4,8 --json $OUT/render_path.json`` (its python3 has numpy and Pillow).
"""

import argparse
import json
import math
import os
import select
import signal
import subprocess
import sys
import time

import myriad


def start_server(path, lights, extra):
    args = [path, "--port", "0", "--host", "127.0.0.1", "--lights", str(lights), *extra]
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    seen = b""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        ready, _, _ = select.select([process.stdout], [], [], 1.0)
        if ready:
            chunk = os.read(process.stdout.fileno(), 4096)
            if not chunk:
                break
            seen += chunk
            if b"http://" in seen and b"\n" in seen[seen.index(b"http://"):]:
                start = seen.index(b"http://")
                return process, seen[start:seen.index(b"\n", start)].decode().strip()
    process.kill()
    sys.exit(f"{path} did not start")


def orbit(count):
    for i in range(count):
        angle = 2 * math.pi * i / max(count, 1)
        yield {"eye": [9 * math.cos(angle), 3.5 + math.sin(3 * angle), 9 * math.sin(angle)],
               "target": [0.0, 0.5, 0.0]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", help="a running server (else --server starts one)")
    parser.add_argument("--server", help="the myriad-server binary to start")
    parser.add_argument("--server-args", default="", help="more flags for the started server")
    parser.add_argument("--lights", type=int, default=100000)
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--targets", default="final,depth,instance-id")
    parser.add_argument("--concurrency", default="1,2,4")
    parser.add_argument("--warmup", type=int, default=8, help="frames rendered before timing")
    parser.add_argument("--json", help="also write the results to this file")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    targets = args.targets.split(",")
    process = None
    url = args.url
    # A SIGTERM (a timeout) still stops the server this script started.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    if url is None:
        if not args.server:
            sys.exit("give --url or --server")
        process, url = start_server(args.server, args.lights, args.server_args.split())
    results = []
    try:
        client = myriad.Client(url)
        info = client.info()
        device = info["device"]["name"]
        with client.session() as session:
            session.generate_lights(args.lights, seed=1)
            for concurrency in (int(c) for c in args.concurrency.split(",")):
                list(session.render_path(orbit(args.warmup), targets, width, height,
                                         concurrency=concurrency))
                start = time.monotonic()
                count = 0
                for frame in session.render_path(orbit(args.frames), targets, width, height,
                                                 concurrency=concurrency):
                    assert frame.index == count
                    count += 1
                seconds = time.monotonic() - start
                result = {"device": device, "size": f"{width}x{height}", "lights": args.lights,
                          "targets": targets, "frames": count, "concurrency": concurrency,
                          "seconds": round(seconds, 2),
                          "framesPerSecond": round(count / seconds, 1),
                          "npz": "npz" in client.formats()}
                results.append(result)
                print(f"concurrency {concurrency}: {count} frames in {seconds:.1f} s = "
                      f"{count / seconds:.1f} frames/s ({device}, {width}x{height}, "
                      f"{args.lights} lights, {'+'.join(targets)})", flush=True)
    finally:
        if process is not None:
            process.terminate()
            process.wait(timeout=30)
    print(json.dumps(results))
    if args.json:
        with open(args.json, "w") as out:
            json.dump(results, out, indent=1)


if __name__ == "__main__":
    main()
