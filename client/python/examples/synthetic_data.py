#!/usr/bin/env python3
"""Synthetic data from a remote Myriad: a model, 100 lights, a camera orbit, a dataset on disk.

    python3 synthetic_data.py --url http://127.0.0.1:8080 --out dataset/ \
        [--model path/to/model.glb] [--frames 120] [--size 640x480] [--concurrency 4]

Writes DIR/final_NNNNN.png, depth_NNNNN.npy, normal_NNNNN.npy, instance-id_NNNNN.png and
DIR/metadata.json (intrinsics and pose of every frame; myriad/dataset.py has the layout).
"""

import argparse
import math
import time

import myriad
from myriad import dataset


def orbit(frames, bounds):
    """Cameras on a circle around the model's bounds, looking at its centre."""
    low, high = bounds["min"], bounds["max"]
    centre = [(a + b) / 2 for a, b in zip(low, high)]
    size = max(b - a for a, b in zip(low, high))
    radius, height = 1.2 * size, centre[1] + 0.4 * size
    for i in range(frames):
        angle = 2 * math.pi * i / frames
        yield {"eye": [centre[0] + radius * math.cos(angle), height,
                       centre[2] + radius * math.sin(angle)],
               "target": centre, "near": 0.01 * size, "far": 10 * size}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default="http://127.0.0.1:8080")
    parser.add_argument("--out", default="dataset")
    parser.add_argument("--model", help="a model file to upload (default: the built-in scene)")
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--size", default="640x480")
    parser.add_argument("--concurrency", type=int, default=4)
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))

    with myriad.Client(args.url).session() as session:
        if args.model:
            session.set_model(args.model)
        session.generate_lights(100, seed=7)
        bounds = session.state()["model"]["bounds"]
        start = time.monotonic()
        frames = session.render_path(orbit(args.frames, bounds),
                                     ["final", "depth", "normal", "instance-id"], width, height,
                                     concurrency=args.concurrency)
        metadata = dataset.write(frames, args.out)
        seconds = time.monotonic() - start
    print(f"{args.frames} frames of {width}x{height} in {seconds:.1f} s "
          f"({args.frames / seconds:.1f} frames/s): {metadata}")


if __name__ == "__main__":
    main()
