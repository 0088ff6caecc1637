#!/usr/bin/env python3
# Issue 18's still, pass by pass: where a full-quality 1280x720 frame of the built-in scene spends
# its time on the server, from the Server-Timing header (GPU timestamps per pass, then readback and
# encode). Starts each given myriad-server binary on a free port, opens a session, asks for --warmup
# frames and then --frames more, and prints each pass's median (min-max) in ms for every binary.
# With several binaries and --rounds N it alternates them (A B A B ...), so two builds are compared
# in the same minutes on this noisy machine. Not a test: it asserts nothing.
# Usage: scripts/still-passes.py BINARY [BINARY ...] [--frames 8] [--warmup 2] [--rounds 2]
#                                [--size 1280x720] [--json FILE]
import argparse
import json
import re
import statistics
import subprocess
import sys
import threading
import time
import urllib.request


def listening_port(server):
    """The port a server started with --port 0 announces ("Myriad listening on http://...:PORT")."""
    for line in server.stdout:
        if "listening on" in line:
            # The rest of its output is read and dropped, so that a full pipe never stalls it.
            threading.Thread(target=server.stdout.read, daemon=True).start()
            return int(line.strip().rsplit(":", 1)[1])
    sys.exit(f"still-passes: the server exited ({server.wait()}) before it listened")


def measure(binary, args):
    """One server, one session: the Server-Timing durations of each timed frame, by pass."""
    server = subprocess.Popen([binary, "--port", "0"], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True)
    try:
        base = f"http://127.0.0.1:{listening_port(server)}"
        created = json.load(urllib.request.urlopen(
            urllib.request.Request(base + "/v1/sessions", data=b"", method="POST")))
        width, height = args.size.split("x")
        url = (f"{base}/v1/sessions/{created['id']}/frame?width={width}&height={height}"
               f"&format=jpeg&quality=90")
        headers = {"Authorization": "Bearer " + created["token"]}
        passes = {}
        for i in range(args.warmup + args.frames):
            start = time.monotonic()
            with urllib.request.urlopen(urllib.request.Request(url, headers=headers)) as response:
                response.read()
                timing = response.headers.get("Server-Timing", "")
            wall = (time.monotonic() - start) * 1000
            if i < args.warmup:
                continue
            for name, ms in re.findall(r"([\w-]+);dur=([\d.]+)", timing):
                passes.setdefault(name, []).append(float(ms))
            passes.setdefault("wall", []).append(wall)
        return passes
    finally:
        server.terminate()
        server.wait()


def summary(passes):
    return {name: {"median": round(statistics.median(v), 1), "min": round(min(v), 1),
                   "max": round(max(v), 1), "n": len(v)} for name, v in passes.items()}


def main():
    parser = argparse.ArgumentParser(
        description="Server-Timing medians of a session's stills, binaries alternated")
    parser.add_argument("binaries", nargs="+")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--json")
    args = parser.parse_args()
    runs = []
    for round_index in range(args.rounds):
        for binary in args.binaries:
            with open("/proc/loadavg") as f:
                load = [float(x) for x in f.read().split()[:3]]
            result = summary(measure(binary, args))
            runs.append({"binary": binary, "round": round_index + 1, "loadAverageStart": load,
                         "utc": time.strftime("%H:%M:%S", time.gmtime()), "passes": result})
            timed = {k: v for k, v in result.items() if k not in ("queue", "wall")}
            print(f"{binary} round {round_index + 1} (load {load[0]}): " +
                  " ".join(f"{k} {v['median']}" for k, v in result.items()) +
                  f" | sum of medians {sum(v['median'] for v in timed.values()):.1f}", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"size": args.size, "frames": args.frames, "warmup": args.warmup,
                       "runs": runs}, f, indent=1)


if __name__ == "__main__":
    main()
