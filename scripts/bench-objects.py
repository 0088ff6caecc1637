#!/usr/bin/env python3
"""Scenes of many objects, measured through the HTTP API (issue 29's benchmarks).

Starts SERVER (a myriad-server binary, or a command line such as ".devpack/run.sh
.devpack/bin/myriad-server"), then, in one session:

 1. frame: ASSET_TRIANGLES-triangle sphere asset (an OBJ made here), OBJECTS objects of it on a
    grid in view, LIGHTS generated lights; WIDTHxHEIGHT frames of the default technique, GPU pass
    times from Server-Timing after WARMUP frames: the median of FRAMES frames (the sum of the
    passes, and each pass).
 2. patch: in a second session, MOVE_OBJECTS objects of a MOVE_ASSET_TRIANGLES-triangle sphere
    (added 10,000 a request); then, REPEATS times, a PATCH of one object's transform followed by a
    PNG frame of PATCH_SIZE: the wall time from sending the PATCH to the frame's last byte
    (loopback), median and p90; and the PATCH's own answer time.

Prints one JSON object (and writes it to --json). Everything is the server's default path except
what the arguments name.
"""
import argparse
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request


def sphere_obj(triangles):
    """A UV sphere with about `triangles` triangles, as OBJ text."""
    rings = max(4, int(math.sqrt(triangles / 4)))
    segments = max(8, triangles // (2 * rings))
    lines = []
    for r in range(rings + 1):
        phi = math.pi * r / rings
        for s in range(segments + 1):
            theta = 2 * math.pi * s / segments
            x, y, z = math.sin(phi) * math.cos(theta), math.cos(phi), math.sin(phi) * math.sin(theta)
            lines.append(f"v {0.5 * x:.6f} {0.5 * y:.6f} {0.5 * z:.6f}")
            lines.append(f"vn {x:.6f} {y:.6f} {z:.6f}")
    count = 0
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s + 1
            b = a + segments + 1
            lines.append(f"f {a}//{a} {b}//{b} {a + 1}//{a + 1}")
            lines.append(f"f {a + 1}//{a + 1} {b}//{b} {b + 1}//{b + 1}")
            count += 2
    return "\n".join(lines) + "\n", count


class Server:
    def __init__(self, command, args):
        self.proc = subprocess.Popen(command + ["--port", "0", "--host", "127.0.0.1"] + args,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.time() + 120
        self.log = []
        while time.time() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError("server exited: " + "".join(self.log[-20:]))
            self.log.append(line)
            m = re.search(r"listening on (http://\S+)", line)
            if m:
                self.url = m.group(1)
                return
        raise RuntimeError("server did not start")

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(30)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def request(method, url, token=None, body=None, content_type="application/json"):
    data = None
    headers = {}
    if body is not None:
        data = body if isinstance(body, bytes) else json.dumps(body).encode()
        headers["Content-Type"] = content_type
    if token:
        headers["Authorization"] = "Bearer " + token
    req = urllib.request.Request(url, data=data, method=method, headers=headers)
    with urllib.request.urlopen(req, timeout=600) as r:
        return r.status, dict(r.headers), r.read()


def server_timing(header):
    """{pass: milliseconds} of a Server-Timing header (dur= entries)."""
    out = {}
    for part in header.split(","):
        m = re.match(r"\s*([A-Za-z0-9_-]+);dur=([0-9.]+)", part)
        if m:
            out[m.group(1)] = float(m.group(2))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("server", help="myriad-server, or a command line (split on spaces)")
    p.add_argument("--objects", type=int, default=10000)
    p.add_argument("--asset-triangles", type=int, default=10000)
    p.add_argument("--lights", type=int, default=1000000)
    p.add_argument("--light-radius", type=float, nargs=2, default=[0.25, 1.0])
    p.add_argument("--width", type=int, default=1920)
    p.add_argument("--height", type=int, default=1080)
    p.add_argument("--warmup", type=int, default=5)
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--move-objects", type=int, default=100000)
    p.add_argument("--move-asset-triangles", type=int, default=500)
    p.add_argument("--repeats", type=int, default=30)
    p.add_argument("--patch-size", default="320x180", help="the frame after each PATCH")
    p.add_argument("--server-arg", action="append", default=[], help="passed to the server")
    p.add_argument("--json", help="also write the result here")
    a = p.parse_args()

    server = Server(a.server.split(), ["--max-lights", str(max(a.lights, 100000)),
                                       "--max-objects", str(max(a.objects, a.move_objects) + 1),
                                       "--max-body-bytes", str(64 << 20)] + a.server_arg)
    result = {"command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    try:
        _, _, body = request("GET", server.url + "/v1/info")
        info = json.loads(body)
        result["device"] = info["device"]
        def session(triangles):
            _, _, body = request("POST", server.url + "/v1/sessions", body={})
            created = json.loads(body)
            base = f"{server.url}/v1/sessions/{created['id']}"
            token = created["token"]
            request("PATCH", base + "/objects/1", token, {"visible": False})
            obj, made = sphere_obj(triangles)
            _, _, body = request("POST", base + "/assets?filename=sphere.obj", token, obj.encode(),
                                 "application/octet-stream")
            return base, token, json.loads(body)["id"], made

        def add(base, token, asset, count, spacing):
            side = math.ceil(math.sqrt(count))
            t0 = time.perf_counter()
            for first in range(0, count, 10000):
                batch = [{"asset": asset, "transform": {"translation": [
                    spacing * ((i % side) - side / 2), 0.5, -spacing * (i // side)]}}
                    for i in range(first, min(count, first + 10000))]
                request("POST", base + "/objects", token, {"objects": batch})
            return time.perf_counter() - t0

        # 1. Frame time.
        base, token, asset, result["assetTriangles"] = session(a.asset_triangles)
        side = math.ceil(math.sqrt(a.objects))
        result["addObjectsSeconds"] = add(base, token, asset, a.objects, 1.2)
        extent = 1.2 * side
        request("PUT", base + "/camera", token, {"eye": [0, extent * 0.6, extent * 0.35],
                                                  "target": [0, 0, -extent * 0.45], "up": [0, 1, 0],
                                                  "fovY": 60, "near": 0.1, "far": extent * 3})
        if a.lights:
            # Radii as the objects' spacing (1.2 m), not the generator's default (a share of the
            # whole scene's diagonal: 7 to 25 m over a 120 m grid, every pixel in thousands).
            request("POST", base + "/lights/generate", token,
                    {"count": a.lights, "seed": 7, "radius": a.light_radius})
        passes = []
        for i in range(a.warmup + a.frames):
            _, headers, _ = request("GET", f"{base}/frame?format=jpeg&width={a.width}&height={a.height}", token)
            if i >= a.warmup:
                passes.append(server_timing(headers.get("Server-Timing", "")))
        gpu_names = [n for n in passes[0] if n not in ("readback", "encode", "queue", "copy")]
        result["frame"] = {
            "objects": a.objects, "lights": a.lights, "size": f"{a.width}x{a.height}",
            "technique": headers.get("X-Myriad-Technique"),
            "gpuMsMedian": statistics.median(sum(f.get(n, 0.0) for n in gpu_names) for f in passes),
            "passesMsMedian": {n: statistics.median(f.get(n, 0.0) for f in passes) for n in passes[0]},
        }
        # 2. A PATCH among many objects to the next frame's bytes.
        base, token, asset, result["moveAssetTriangles"] = session(a.move_asset_triangles)
        request("DELETE", base + "/lights", token)
        result["addMoveObjectsSeconds"] = add(base, token, asset, a.move_objects, 1.2)
        side = math.ceil(math.sqrt(a.move_objects))
        request("PUT", base + "/camera", token, {"eye": [0, 20, 15], "target": [0, 0, -10],
                                                  "up": [0, 1, 0], "fovY": 60, "near": 0.1,
                                                  "far": 2.0 * side})
        w, h = a.patch_size.split("x")
        for _ in range(3):
            request("GET", f"{base}/frame?format=png&width={w}&height={h}", token)
        walls, patches, after = [], [], []
        target = 2 + side // 2  # in the first row, in view
        for i in range(a.repeats):
            t0 = time.perf_counter()
            request("PATCH", f"{base}/objects/{target}", token,
                    {"transform": {"translation": [0.1 * (i % 7), 0.5 + 0.05 * (i % 5), -1.0]}})
            t1 = time.perf_counter()
            _, headers, _ = request("GET", f"{base}/frame?format=png&width={w}&height={h}", token)
            t2 = time.perf_counter()
            after.append(server_timing(headers.get("Server-Timing", "")))
            patches.append((t1 - t0) * 1000)
            walls.append((t2 - t0) * 1000)
        walls.sort()
        result["patch"] = {
            "objects": a.move_objects, "frame": a.patch_size,
            "patchToFrameMsMedian": statistics.median(walls),
            "patchToFrameMsP90": walls[int(0.9 * (len(walls) - 1))],
            "patchMsMedian": statistics.median(patches),
            "framePassesMsMedian": {n: statistics.median(f.get(n, 0.0) for f in after) for n in after[0]},
        }
    finally:
        server.stop()
    text = json.dumps(result, indent=2)
    print(text)
    if a.json:
        with open(a.json, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
