#!/usr/bin/env python3
"""myriad-server --batch with "targets" (service/batch.h): the dataset layout of issue 32.

A server makes a session and hands out its snapshot; a spec asks for final as PNG, depth as EXR,
normal as .npy and instance-id as 16-bit PNG over a path of 3 cameras, 2 frames per index. Index
0 and index 1 run at once into one directory; then DIR holds <target>_<NNNNN>.<ext> per target
and frame and a metadata.json listing the 3 frames (K, world_from_camera, near, far, time, files).
Each file is checked against the same frame fetched through the HTTP API from a session restored
from the snapshot: final PNG byte-equal to GET .../frame?format=png, normal.npy (numpy.load)
bit-equal to format=raw, instance-id PNG16's values equal to raw ids, depth EXR's header naming
depth.Z (FLOAT) and K. An old spec (no "targets") still writes frame-NNNNNN.png, and a bad
target format is refused with a sentence naming it.

Usage: dataset_test.py MYRIAD_SERVER. Exit 0 pass, 1 fail.
"""
import http.client
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib

import numpy as np

QUERY = "width=64&height=48"
TARGETS = {"final": "png", "depth": "exr", "normal": "npy", "instance-id": "png16"}
EXT = {"png": "png", "png16": "png", "npy": "npy", "exr": "exr"}
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)
    return condition


def request(port, method, path, body=None, token=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    headers = {}
    if token:
        headers["Authorization"] = "Bearer " + token
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        headers["Content-Type"] = "application/json"
    elif method in ("POST", "PUT", "PATCH"):
        data = b""
    c.request(method, path, body=data, headers=headers)
    r = c.getresponse()
    payload = r.read()
    c.close()
    return r.status, payload


def png16_values(data):
    """A 16-bit greyscale PNG's samples, decoded here (zlib + the five PNG filters)."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", body[:10])
            assert depth == 16 and colour == 0, (depth, colour)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride, bpp = width * 2, 2
    rows, prior = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prior[i]
            c = prior[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 0xFF
            elif f == 2:
                line[i] = (line[i] + b) & 0xFF
            elif f == 3:
                line[i] = (line[i] + ((a + b) >> 1)) & 0xFF
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 0xFF
        rows.append(bytes(line))
        prior = line
    return np.frombuffer(b"".join(rows), dtype=">u2").astype(np.uint32)


def exr_header(data):
    """An OpenEXR file's header attributes: name -> (type, bytes)."""
    check(data[:4] == b"\x76\x2f\x31\x01", "not an OpenEXR file")
    pos, attributes = 8, {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        size = struct.unpack("<i", data[type_end + 1:type_end + 5])[0]
        attributes[data[pos:name_end].decode()] = (data[name_end + 1:type_end].decode(),
                                                   data[type_end + 5:type_end + 5 + size])
        pos = type_end + 5 + size
    return attributes


def main():
    server = sys.argv[1]
    work = tempfile.mkdtemp(prefix="myriad-dataset-")
    process = subprocess.Popen([server, "--host", "127.0.0.1", "--port", "0", "--lights", "8",
                                "--validate"], stdout=subprocess.PIPE,
                               stderr=open(os.path.join(work, "server.log"), "wb"))
    try:
        m = re.search(r"listening on http://127\.0\.0\.1:(\d+)", process.stdout.readline().decode())
        if not check(m is not None, "the server did not start"):
            return 1
        port = int(m.group(1))
        status, body = request(port, "POST", "/v1/sessions")
        created = json.loads(body)
        path, token = "/v1/sessions/" + created["id"], created["token"]
        status, body = request(port, "GET", path + "/snapshot", None, token)
        check(status == 200, f"GET snapshot -> {status}")
        snapshot = json.loads(body)
        cameras = [{"eye": [4 - i, 2.5, 3 + i], "target": [0, 0.5, 0], "up": [0, 1, 0],
                    "fovY": 45, "near": 0.05, "far": 100} for i in range(3)]
        spec_path = os.path.join(work, "spec.json")
        with open(spec_path, "w") as f:
            json.dump({"snapshot": snapshot, "cameras": cameras, "frame": QUERY,
                       "framesPerIndex": 2, "targets": TARGETS}, f)
        out = os.path.join(work, "dataset")
        t = time.monotonic()
        jobs = [subprocess.Popen([server, "--batch", spec_path, "--index", str(i), "--out", out,
                                  "--validate"], stderr=subprocess.PIPE) for i in (0, 1)]
        for index, job in enumerate(jobs):
            _, err = job.communicate(timeout=400)
            check(job.returncode == 0, f"index {index} exited {job.returncode}: {err.decode()[-2000:]}")
        print(f"indices 0 and 1 wrote {sorted(os.listdir(out))} in {time.monotonic() - t:.1f} s",
              flush=True)
        expected = sorted([f"{t}_{i:05d}.{EXT[f]}" for i in range(3) for t, f in TARGETS.items()] +
                          ["metadata.json", "metadata.json.lock"])
        check(sorted(os.listdir(out)) == expected, f"files {sorted(os.listdir(out))}")
        with open(os.path.join(out, "metadata.json")) as f:
            metadata = json.load(f)
        check(metadata.get("format") == "myriad-dataset" and metadata.get("version") == 1,
              f"metadata format/version {metadata.get('format')} {metadata.get('version')}")
        frames = metadata.get("frames", [])
        check([f["index"] for f in frames] == [0, 1, 2], f"metadata frames {[f.get('index') for f in frames]}")

        status, body = request(port, "POST", "/v1/sessions", {"snapshot": snapshot})
        restored = json.loads(body)
        rpath, rtoken = "/v1/sessions/" + restored["id"], restored["token"]
        for i, entry in enumerate(frames):
            check(entry["width"] == 64 and entry["height"] == 48, f"frame {i} size")
            check(entry["files"] == {t: f"{t}_{i:05d}.{EXT[f]}" for t, f in TARGETS.items()},
                  f"frame {i} files {entry['files']}")
            request(port, "PUT", rpath + "/camera", cameras[i], rtoken)
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
            c.request("GET", f"{rpath}/frame?{QUERY}&format=raw&target=depth",
                      headers={"Authorization": "Bearer " + rtoken})
            r = c.getresponse()
            r.read()
            intrinsics = json.loads(r.getheader("X-Myriad-Intrinsics"))
            pose = json.loads(r.getheader("X-Myriad-Pose"))["worldFromCamera"]
            c.close()
            k = np.array(entry["K"])
            check(np.allclose(k, [[intrinsics["fx"], 0, intrinsics["cx"]],
                                  [0, intrinsics["fy"], intrinsics["cy"]], [0, 0, 1]]),
                  f"frame {i}: K {entry['K']} vs {intrinsics}")
            check(np.allclose(entry["world_from_camera"], pose, atol=1e-6), f"frame {i}: pose")
            check(abs(entry["near"] - 0.05) < 1e-6 and abs(entry["far"] - 100) < 1e-4,
                  f"frame {i}: near/far {entry['near']} {entry['far']}")

            status, png = request(port, "GET", f"{rpath}/frame?{QUERY}&format=png", None, rtoken)
            with open(os.path.join(out, entry["files"]["final"]), "rb") as f:
                check(f.read() == png, f"frame {i}: final PNG differs from the API's")
            status, raw = request(port, "GET", f"{rpath}/frame?{QUERY}&format=raw&target=normal", None, rtoken)
            normal = np.load(os.path.join(out, entry["files"]["normal"]))
            check(normal.dtype == np.float32 and normal.shape == (48, 64, 3), f"normal {normal.dtype} {normal.shape}")
            check(normal.tobytes() == raw, f"frame {i}: normal.npy differs from format=raw")
            status, raw = request(port, "GET", f"{rpath}/frame?{QUERY}&format=raw&target=instance-id", None, rtoken)
            with open(os.path.join(out, entry["files"]["instance-id"]), "rb") as f:
                ids = png16_values(f.read())
            check(np.array_equal(ids, np.frombuffer(raw, dtype="<u4")), f"frame {i}: instance-id PNG16 differs")
            check(np.count_nonzero(ids) > 0, f"frame {i}: no object in instance-id")
            with open(os.path.join(out, entry["files"]["depth"]), "rb") as f:
                header = exr_header(f.read())
            check(header.get("K", ("",))[0] == "m33d", f"frame {i}: EXR K {header.get('K', ('',))[0]}")
            channels = header.get("channels", ("", b""))[1]
            # chlist: name\0, int32 pixel type (2 = FLOAT), ...
            check(b"depth.Z\0" + struct.pack("<i", 2) in channels, f"frame {i}: EXR channels {channels!r}")
            print(f"frame {i}: final PNG, normal.npy, instance-id PNG16 equal to the API's; "
                  f"depth EXR header has depth.Z and K", flush=True)

        # A bad format for a target: one sentence naming it, exit 1.
        bad = os.path.join(work, "bad.json")
        with open(bad, "w") as f:
            json.dump({"snapshot": snapshot, "cameras": cameras[:1], "frame": QUERY,
                       "targets": {"normal": "png16"}}, f)
        r = subprocess.run([server, "--batch", bad, "--out", os.path.join(work, "bad")],
                           capture_output=True, text=True, timeout=120)
        check(r.returncode == 1 and "/targets/normal" in r.stderr,
              f"bad spec: exit {r.returncode}, stderr {r.stderr[-500:]!r}")
    finally:
        process.terminate()
        process.wait(timeout=60)
        log = open(os.path.join(work, "server.log"), "rb").read().decode(errors="replace")
        check("VUID" not in log and "Validation Error" not in log,
              "the server logged validation messages")
        shutil.rmtree(work, ignore_errors=True)
    print("dataset_test: " + ("PASS" if not failures else f"{len(failures)} failures"), flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
