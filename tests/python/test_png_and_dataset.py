"""The package's PNG reader and writer (no server), and the dataset writer (with one)."""

from __future__ import annotations

import io
import json
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

import myriad
from myriad import dataset, png


def filtered_png(image: np.ndarray, filter_type: int) -> bytes:
    """A reference encoder: every row with one filter type, straight from the PNG spec."""
    height, width, channels = image.shape
    bpp = channels
    rows = image.reshape(height, width * channels).astype(np.int64)
    out = bytearray()
    for y in range(height):
        row = rows[y]
        prior = rows[y - 1] if y else np.zeros_like(row)
        out.append(filter_type)
        for x in range(len(row)):
            a = row[x - bpp] if x >= bpp else 0
            b = prior[x]
            c = prior[x - bpp] if x >= bpp else 0
            if filter_type == 0:
                predictor = 0
            elif filter_type == 1:
                predictor = a
            elif filter_type == 2:
                predictor = b
            elif filter_type == 3:
                predictor = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                predictor = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            out.append((row[x] - predictor) & 0xFF)
    colour = {1: 0, 3: 2, 4: 6}[channels]

    def chunk(kind, payload):
        return (struct.pack(">I", len(payload)) + kind + payload
                + struct.pack(">I", zlib.crc32(kind + payload)))
    return (png.SIGNATURE + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour,
                                                      0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(out))) + chunk(b"IEND", b""))


@pytest.mark.parametrize("filter_type", [0, 1, 2, 3, 4])
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_png_reader_undoes_every_filter(filter_type, channels):
    rng = np.random.default_rng(filter_type * 10 + channels)
    image = rng.integers(0, 256, (9, 13, channels), dtype=np.uint8)
    decoded = png.decode(filtered_png(image, filter_type))
    expected = image[:, :, 0] if channels == 1 else image
    assert decoded.dtype == np.uint8 and np.array_equal(decoded, expected)


def test_png_writer_is_read_back_by_pillow():
    rng = np.random.default_rng(5)
    rgb = rng.integers(0, 256, (17, 11, 3), dtype=np.uint8)
    with Image.open(io.BytesIO(png.encode(rgb))) as image:
        assert image.mode == "RGB" and np.array_equal(np.asarray(image), rgb)
    ids = rng.integers(0, 65536, (6, 7), dtype=np.uint16)
    with Image.open(io.BytesIO(png.encode(ids))) as image:
        assert image.mode in ("I", "I;16") and np.array_equal(np.asarray(image), ids)
    assert np.array_equal(png.decode(png.encode(ids)), ids)
    with pytest.raises(ValueError, match="uint8"):
        png.encode(np.zeros((2, 2, 3), dtype=np.float32))


def test_dataset_writer_layout_read_back_with_numpy_and_pillow(session, tmp_path):
    cameras = [{"eye": [6.0, 3.0, 6.0 - i]} for i in range(3)]
    targets = ["final", "depth", "normal", "instance-id", "albedo"]
    path = session.render_path(cameras, targets, 40, 30, concurrency=2, times=[0.0, 0.5, 1.0])
    kept = []

    def keep(frames):
        for frame in frames:
            kept.append(frame)
            yield frame
    metadata_path = dataset.write(keep(path), tmp_path / "set")
    document = json.loads(metadata_path.read_text())
    assert document["format"] == "myriad-dataset" and document["version"] == 1
    assert [f["index"] for f in document["frames"]] == [0, 1, 2]
    assert dataset.read_metadata(tmp_path / "set") == document
    for entry, frame in zip(document["frames"], kept):
        assert set(entry) == {"index", "time", "width", "height", "K", "world_from_camera",
                              "near", "far", "files"}
        i = entry["index"]
        assert entry["files"] == {"final": f"final_{i:05d}.png", "depth": f"depth_{i:05d}.npy",
                                  "normal": f"normal_{i:05d}.npy",
                                  "instance-id": f"instance-id_{i:05d}.png",
                                  "albedo": f"albedo_{i:05d}.npy"}
        assert entry["time"] == [0.0, 0.5, 1.0][i]
        assert (entry["width"], entry["height"]) == (40, 30)
        assert np.array_equal(np.array(entry["K"]), frame.K)
        assert np.array_equal(np.array(entry["world_from_camera"]), frame.world_from_camera)
        assert entry["near"] == frame.near and entry["far"] == frame.far
        folder = tmp_path / "set"
        with Image.open(folder / entry["files"]["final"]) as final:
            assert final.mode == "RGB" and np.array_equal(np.asarray(final), frame["final"])
        depth = np.load(folder / entry["files"]["depth"])
        assert depth.dtype == np.float32 and np.array_equal(depth, frame["depth"])
        normal = np.load(folder / entry["files"]["normal"])
        assert normal.shape == (30, 40, 3) and np.array_equal(normal, frame["normal"])
        with Image.open(folder / entry["files"]["instance-id"]) as ids:
            assert np.array_equal(np.asarray(ids).astype(np.uint32), frame["instance-id"])
        assert np.array_equal(np.load(folder / entry["files"]["albedo"]), frame["albedo"])
    assert sorted(p.name for p in (tmp_path / "set").iterdir()) == sorted(
        ["metadata.json"] + [name for e in document["frames"] for name in e["files"].values()])


def test_dataset_writer_refuses_ids_a_16_bit_png_cannot_hold(tmp_path):
    frame = myriad.Frame({"instance-id": np.full((2, 2), 70000, dtype=np.uint32)},
                         K=np.eye(3), world_from_camera=np.eye(4), near=0.1, far=10.0,
                         width=2, height=2)
    with dataset.Writer(tmp_path) as writer:
        with pytest.raises(ValueError, match="70000"):
            writer.write(frame)
    with pytest.raises(RuntimeError, match="OpenEXR"):
        if dataset._OpenEXR is None:
            dataset.Writer(tmp_path, exr=True)
        else:
            raise RuntimeError("OpenEXR importable: nothing to refuse")
