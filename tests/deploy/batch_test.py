#!/usr/bin/env python3
"""myriad-server --batch (service/batch.h): the frames two indices of a job write are byte-equal to
the same frames fetched through the HTTP API.

A server makes a session (lights and a material edited) and hands out its snapshot; the spec names
it, a camera path of 5 cameras and 2 frames per index. Index 0 (--index 0) and index 1 (as a
Kubernetes Indexed Job gives it: JOB_COMPLETION_INDEX=1) run at once, with validation; then a
session restored from the same snapshot through POST /v1/sessions gets each camera (PUT .../camera)
and its frame (GET .../frame with the spec's query): the PNG bytes must be equal. Index 2 writes
frame 4 only, index 3 none; a spec with a bad camera is refused with a sentence naming it.

Usage: batch_test.py MYRIAD_SERVER. Exit 0 pass, 1 fail.
"""
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from server_script import Server, check, request  # noqa: E402 (tests/server_script.py)

QUERY = "width=64&height=48&format=png"
def main():
    server = sys.argv[1]
    running = Server(server, "myriad-batch-")
    work, port = running.work, running.port
    try:
        if port is None:
            return 1

        status, _, body = request(port, "POST", "/v1/sessions")
        check(status == 201, f"POST /v1/sessions -> {status}")
        created = json.loads(body)
        path, token = "/v1/sessions/" + created["id"], created["token"]
        light = {"position": [0.5, 1.2, 0.8], "radius": 5, "color": [1, 0.4, 0.2], "intensity": 6,
                 "falloff": 1}
        status, _, _ = request(port, "POST", path + "/lights", {"lights": [light]}, token)
        check(status == 201, f"POST lights -> {status}")
        status, _, _ = request(port, "PATCH", path + "/materials/0",
                            {"baseColor": [0.2, 0.7, 0.9], "roughness": 0.35}, token)
        check(status == 200, f"PATCH material -> {status}")
        status, _, body = request(port, "GET", path + "/snapshot", None, token)
        check(status == 200, f"GET snapshot -> {status}")
        snapshot = json.loads(body)

        cameras = [{"eye": [4 * (1 - i / 5), 2.5, 3 + i], "target": [0, 0.5, 0], "up": [0, 1, 0],
                    "fovY": 45, "near": 0.05, "far": 100} for i in range(5)]
        spec_path = os.path.join(work, "spec.json")
        with open(spec_path, "w") as f:
            json.dump({"snapshot": snapshot, "cameras": cameras, "frame": QUERY,
                       "framesPerIndex": 2}, f)
        out = os.path.join(work, "frames")

        # Two indices at once, as two pods of the Indexed Job.
        t = time.monotonic()
        env = dict(os.environ, JOB_COMPLETION_INDEX="1")
        jobs = [subprocess.Popen([server, "--batch", spec_path, "--index", "0", "--out", out,
                                  "--validate"], stderr=subprocess.PIPE),
                subprocess.Popen([server, "--batch", spec_path, "--out", out, "--validate"],
                                 stderr=subprocess.PIPE, env=env)]
        for index, job in enumerate(jobs):
            _, err = job.communicate(timeout=240)
            check(job.returncode == 0,
                  f"batch index {index} exited {job.returncode}: {err.decode()[-2000:]}")
        print(f"indices 0 and 1 rendered in {time.monotonic() - t:.1f} s: "
              f"{sorted(os.listdir(out))}", flush=True)
        check(sorted(os.listdir(out)) == [f"frame-{i:06d}.png" for i in range(4)],
              f"indices 0 and 1 wrote {sorted(os.listdir(out))}")

        # The same frames through the HTTP API, from the same snapshot.
        status, _, body = request(port, "POST", "/v1/sessions", {"snapshot": snapshot})
        check(status == 201, f"POST /v1/sessions with the snapshot -> {status}")
        restored = json.loads(body)
        rpath, rtoken = "/v1/sessions/" + restored["id"], restored["token"]
        for i in range(4):
            status, _, _ = request(port, "PUT", rpath + "/camera", cameras[i], rtoken)
            check(status == 200, f"PUT camera {i} -> {status}")
            status, _, frame = request(port, "GET", f"{rpath}/frame?{QUERY}", None, rtoken)
            check(status == 200, f"GET frame {i} -> {status}")
            with open(os.path.join(out, f"frame-{i:06d}.png"), "rb") as f:
                batch = f.read()
            check(batch == frame, f"frame {i}: batch PNG ({len(batch)} bytes) differs from the "
                                  f"API's ({len(frame)} bytes)")
            print(f"frame {i}: {len(batch)} bytes, byte-equal to the API's: {batch == frame}",
                  flush=True)

        # The last index's share is cut at the path's end; past it, nothing.
        for index, expected in ((2, ["frame-000004.png"]), (3, [])):
            d = os.path.join(work, f"out{index}")
            r = subprocess.run([server, "--batch", spec_path, "--index", str(index), "--out", d],
                               capture_output=True, timeout=120)
            check(r.returncode == 0 and sorted(os.listdir(d)) == expected,
                  f"index {index}: exit {r.returncode}, wrote {os.listdir(d) if os.path.isdir(d) else None}")

        # A bad spec: one sentence naming the member, exit 1.
        bad = os.path.join(work, "bad.json")
        with open(bad, "w") as f:
            json.dump({"snapshot": snapshot, "cameras": [dict(cameras[0], fovY=500)],
                       "frame": QUERY}, f)
        r = subprocess.run([server, "--batch", bad, "--out", os.path.join(work, "bad")],
                           capture_output=True, text=True, timeout=120)
        check(r.returncode == 1 and "/cameras/0/fovY" in r.stderr,
              f"bad spec: exit {r.returncode}, stderr {r.stderr[-500:]!r}")
    finally:
        running.stop()
    return running.verdict()


if __name__ == "__main__":
    sys.exit(main())
