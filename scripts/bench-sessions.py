#!/usr/bin/env python3
"""Many sessions on one host (issue 35): SESSIONS concurrent animated sessions, each its own scene
(LIGHTS generated lights, a seed per session), each watched by one myriad-net-probe streaming
WIDTHxHEIGHT at FPS in CODEC at BITRATE kbit/s, for SECONDS (the first WARMUP not counted).
Reports per stream the pictures delivered a second and the bitrate they carried, and over all
streams the least rate, the median and the largest bitrate, with the server's encode pool figures
(/metrics, read at the end).

Starts SERVER (a myriad-server binary, or a command line such as ".devpack/run.sh
.devpack/bin/myriad-server"). The pictures' quality (PSNR) is not measured here (the stream's
pictures are of a moving scene no still frame matches): myriad-video-settings-bench gives each
codec's PSNR at a bitrate on a rendered-looking animated picture.

Usage: bench-sessions.py SERVER PROBE [--sessions N] [--codec vp9|h264|jpeg] [--size WxH]
       [--fps F] [--bitrate KBPS] [--lights N] [--seconds S] [--warmup S] [--json PATH]
       [-- server flags]
Not a test: run it on a machine otherwise idle and say what else ran.
"""
import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import urllib.request
from concurrent.futures import ThreadPoolExecutor

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("bench_objects", os.path.join(here, "bench-objects.py"))
bench_objects = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench_objects)


def main():
    argv = sys.argv[1:]
    server_flags = []
    if "--" in argv:
        server_flags = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("server", help="myriad-server, or a command line (split on spaces)")
    p.add_argument("probe", help="myriad-net-probe")
    p.add_argument("--sessions", type=int, default=16)
    p.add_argument("--codec", default="vp9", choices=["vp9", "h264", "jpeg"])
    p.add_argument("--size", default="1920x1080")
    p.add_argument("--fps", type=int, default=30)
    p.add_argument("--bitrate", type=int, default=8000)
    p.add_argument("--lights", type=int, default=1000)
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--warmup", type=float, default=5.0)
    p.add_argument("--json")
    a = p.parse_args(argv)

    flags = ["--max-streams", str(max(64, 2 * a.sessions)), "--max-sessions",
             str(max(64, 2 * a.sessions))] + server_flags
    server = bench_objects.Server(a.server.split(), flags)
    try:
        def probe(i):
            cmd = [a.probe, "--url", server.url, "--codec", a.codec, "--size", a.size,
                   "--fps", str(a.fps), "--bitrate", str(a.bitrate), "--mode", "watch",
                   "--seconds", str(a.seconds), "--warmup", str(a.warmup),
                   "--lights", str(a.lights), "--scene", str(i + 1)]
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=a.seconds + 120)
            if r.returncode != 0:
                raise RuntimeError(f"probe {i}: {r.stderr.strip()[-500:]}")
            return json.loads(r.stdout)

        with ThreadPoolExecutor(a.sessions) as pool:
            streams = list(pool.map(probe, range(a.sessions)))
        with urllib.request.urlopen(server.url + "/metrics", timeout=30) as r:
            metrics = [line for line in r.read().decode().splitlines()
                       if line.startswith("myriad_encode") or line.startswith("myriad_render")]
    finally:
        server.stop()

    rates = [s["deliveredFps"] for s in streams]
    kbps = [s.get("kbps", 0.0) for s in streams]
    out = {"sessions": a.sessions, "codec": a.codec, "size": a.size, "fps": a.fps,
           "bitrateKbps": a.bitrate, "lights": a.lights, "seconds": a.seconds - a.warmup,
           "serverFlags": flags, "leastFps": min(rates), "medianFps": statistics.median(rates),
           "streamsAtLeast29Fps": sum(1 for r in rates if r >= 29.0),
           "largestKbps": max(kbps), "medianKbps": statistics.median(kbps),
           "streams": streams, "metrics": metrics}
    text = json.dumps(out, indent=1)
    print(text)
    if a.json:
        with open(a.json, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
