#!/usr/bin/env python3
"""numpy's own reader against Myriad's raw frames (tests/formats_tests.cpp writes the files).

In DIR: every TARGET.npy is loaded with numpy.load and compared, bit for bit, with TARGET.raw
(format=raw's body: little-endian float32, or uint32 for the ids) read with numpy.frombuffer in
the .npy's own shape; frame.npz, when present, is loaded as a user would
(numpy.load(io.BytesIO(body))["depth"]) and each member with a TARGET.raw compared the same way;
its K and world_from_camera are compared with headers.json (X-Myriad-Intrinsics and -Pose).
Final is uint8 HxWx3 in both.

Usage: formats_numpy_check.py DIR. Exit 0 when everything agrees, 1 otherwise.
"""
import io
import json
import os
import sys

import numpy as np

IDS = ("instance-id", "semantic-id", "material-id")
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)


def compare(name, array, raw_path):
    dtype = np.uint32 if name in IDS else np.float32
    check(array.dtype == np.dtype(dtype), f"{name}: dtype {array.dtype}, expected {np.dtype(dtype)}")
    with open(raw_path, "rb") as f:
        raw = np.frombuffer(f.read(), dtype="<u4" if name in IDS else "<f4")
    check(raw.size == array.size, f"{name}: {array.size} values, the raw frame has {raw.size}")
    if raw.size == array.size:
        same = np.array_equal(raw.view(np.uint32), np.ascontiguousarray(array).reshape(-1).view(np.uint32))
        check(same, f"{name}: values differ from the raw frame")
    check(array.ndim in (2, 3), f"{name}: shape {array.shape}")


def main():
    directory = sys.argv[1]
    seen = 0
    for entry in sorted(os.listdir(directory)):
        name, ext = os.path.splitext(entry)
        if ext != ".npy":
            continue
        array = np.load(os.path.join(directory, entry))
        if name == "final":
            check(array.dtype == np.uint8 and array.ndim == 3 and array.shape[2] == 3,
                  f"final.npy: {array.dtype} {array.shape}")
        raw = os.path.join(directory, name + ".raw")
        if os.path.exists(raw):
            compare(name, array, raw)
        seen += 1
    npz_path = os.path.join(directory, "frame.npz")
    if os.path.exists(npz_path):
        with open(npz_path, "rb") as f:
            frame = np.load(io.BytesIO(f.read()))
        for name in frame.files:
            raw = os.path.join(directory, name + ".raw")
            if os.path.exists(raw):
                compare(name, frame[name], raw)
            seen += 1
        depth = frame["depth"]
        check(depth.dtype == np.float32 and depth.ndim == 2, f"npz depth: {depth.dtype} {depth.shape}")
        final = frame["final"]
        check(final.dtype == np.uint8 and final.shape == depth.shape + (3,),
              f"npz final: {final.dtype} {final.shape}")
        with open(os.path.join(directory, "headers.json")) as f:
            headers = json.load(f)
        k = frame["K"]
        i = headers["intrinsics"]
        check(k.dtype == np.float64 and k.shape == (3, 3), f"K: {k.dtype} {k.shape}")
        check(np.allclose(k, [[i["fx"], 0, i["cx"]], [0, i["fy"], i["cy"]], [0, 0, 1]]),
              f"K {k.tolist()} differs from X-Myriad-Intrinsics {i}")
        pose = frame["world_from_camera"]
        check(pose.shape == (4, 4) and np.allclose(pose, headers["pose"], atol=1e-6),
              f"world_from_camera {pose.tolist()} differs from X-Myriad-Pose")
    print(f"formats_numpy_check: {seen} arrays read by numpy {np.__version__}, "
          f"{len(failures)} failures", flush=True)
    return 1 if failures or seen == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
