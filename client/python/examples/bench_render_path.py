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
import statistics
import threading
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


def server_timing(header):
    """Server-Timing's metrics as {name: milliseconds} (pass names, readback, encode, queue)."""
    metrics = {}
    for part in (header or "").split(","):
        fields = part.strip().split(";")
        for field in fields[1:]:
            if field.startswith("dur="):
                metrics[fields[0]] = float(field[4:])
    return metrics


# Server-Timing metrics that are host work on the server, not GPU passes.
HOST_METRICS = ("readback", "extra-targets", "encode", "queue")


def timing_summary(frames_metrics):
    """Medians of the GPU passes summed and of each host metric over the frames."""
    if not frames_metrics:
        return {}
    gpu = [sum(v for k, v in m.items() if k not in HOST_METRICS) for m in frames_metrics]
    summary = {"gpuPassesMs": round(statistics.median(gpu), 3)}
    names = []
    for m in frames_metrics:
        names += [name for name in m if name not in names]
    for name in names:  # each pass and host metric, in the header's order
        values = [m[name] for m in frames_metrics if name in m]
        summary[name + "Ms"] = round(statistics.median(values), 3)
    return summary


def client_split(session, targets, width, height, count, options):
    """Per frame in the main thread, one at a time: the request and its body read, then the
    npz decode, medians in ms (where the client's own time goes)."""
    from myriad import frames as frames_module
    fetch, decode = [], []
    query = {"width": width, "height": height, "target": ",".join(targets), "format": "npz",
             **options}
    for camera in orbit(count):
        query.update({"eye": ",".join(map(repr, camera["eye"])),
                      "look_at": ",".join(map(repr, camera["target"]))})
        t0 = time.perf_counter()
        answer = session._call("GET", "/frame", query=query, ok=(200,))
        t1 = time.perf_counter()
        frames_module.decode_npz(answer.body, targets)
        t2 = time.perf_counter()
        fetch.append((t1 - t0) * 1e3)
        decode.append((t2 - t1) * 1e3)
    # The lights each pixel's shading evaluated (the light-count view), at the path's first
    # camera: the shading pass's work, pairs a pixel.
    first = next(orbit(count))
    counts = session.frame(["light-count"], width, height, **options,
                           eye=",".join(map(repr, first["eye"])),
                           look_at=",".join(map(repr, first["target"])))["light-count"]
    return {"fetchMs": round(statistics.median(fetch), 3),
            "decodeMs": round(statistics.median(decode), 3),
            "bytes": len(answer.body),
            "lightsPerPixelMean": round(float(counts.mean()), 2),
            "lightsPerPixelMax": int(counts.max())}


def fetch_only(session, targets, width, height, count, concurrency, options):
    """Frames a second of bare requests (bodies read, not decoded) over `concurrency`
    connections: the server and transport ceiling, without the client's decoding."""
    query = {"width": width, "height": height, "target": ",".join(targets), "format": "npz",
             **options}
    left = [count]
    lock = threading.Lock()

    def work():
        while True:
            with lock:
                if left[0] == 0:
                    return
                left[0] -= 1
            session._call("GET", "/frame", query=query, ok=(200,))

    threads = [threading.Thread(target=work) for _ in range(concurrency)]
    start = time.monotonic()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return round(count / (time.monotonic() - start), 1)


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
    parser.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                        help="a frame query parameter for every frame (repeatable), e.g. "
                             "markers=false; the default path without it")
    parser.add_argument("--settings", action="append", default=[], metavar="JSON",
                        help="a settings patch applied before the runs (repeatable: each is "
                             "a run of its own after the default one), e.g. '{\"markers\": false}'")
    parser.add_argument("--breakdown", action="store_true",
                        help="also report the Server-Timing medians of each run, the client's "
                             "fetch/decode split one frame at a time, and bare fetches a second")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    targets = args.targets.split(",")
    options = dict(item.split("=", 1) for item in args.option)
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
            runs = [(None, int(c)) for c in args.concurrency.split(",")]
            runs += [(json.loads(p), int(args.concurrency.split(",")[-1])) for p in args.settings]
            for patch, concurrency in runs:
                if patch is not None:
                    session.patch_settings(patch)
                list(session.render_path(orbit(args.warmup), targets, width, height,
                                         concurrency=concurrency, **options))
                start = time.monotonic()
                count = 0
                metrics = []
                for frame in session.render_path(orbit(args.frames), targets, width, height,
                                                 concurrency=concurrency, **options):
                    assert frame.index == count
                    count += 1
                    if args.breakdown:
                        metrics.append(server_timing(frame.headers.get("server-timing")))
                seconds = time.monotonic() - start
                result = {"device": device, "size": f"{width}x{height}", "lights": args.lights,
                          "targets": targets, "frames": count, "concurrency": concurrency,
                          "seconds": round(seconds, 2),
                          "framesPerSecond": round(count / seconds, 1),
                          "npz": "npz" in client.formats(), "options": options,
                          "settingsPatch": patch}
                if args.breakdown:
                    result["serverTiming"] = timing_summary(metrics)
                    result["fetchOnlyFramesPerSecond"] = fetch_only(
                        session, targets, width, height, min(args.frames, 200), concurrency,
                        options)
                results.append(result)
                print(f"{'settings ' + json.dumps(patch) + ', ' if patch else ''}"
                      f"concurrency {concurrency}: {count} frames in {seconds:.1f} s = "
                      f"{count / seconds:.1f} frames/s ({device}, {width}x{height}, "
                      f"{args.lights} lights, {'+'.join(targets)})", flush=True)
                if args.breakdown:
                    print(f"  server timing medians: {result['serverTiming']}; bare fetches "
                          f"(no decode): {result['fetchOnlyFramesPerSecond']} frames/s",
                          flush=True)
            if args.breakdown:
                split = client_split(session, targets, width, height, 30, options)
                results.append({"clientSplit": split})
                print(f"one at a time: {split}", flush=True)
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
