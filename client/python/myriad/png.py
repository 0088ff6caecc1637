"""PNG without dependencies: a reader for the server's frames and a writer for datasets.

Pillow decodes PNG faster and is used when it is importable; these keep the package's only
runtime dependency numpy. The reader takes any non-interlaced 8- or 16-bit grey, grey+alpha, RGB
or RGBA PNG (what ``myriad-server`` writes, whatever filters its encoder picks); the writer makes
8-bit RGB/RGBA and 8- or 16-bit grey images.
"""

from __future__ import annotations

import struct
import zlib
from typing import List, Tuple

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
# colour type -> channels
_CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


def _chunks(data: bytes) -> List[Tuple[bytes, bytes]]:
    if data[:8] != SIGNATURE:
        raise ValueError("not a PNG file (no PNG signature)")
    chunks = []
    at = 8
    while at + 8 <= len(data):
        (length,) = struct.unpack(">I", data[at:at + 4])
        kind = data[at + 4:at + 8]
        payload = data[at + 8:at + 8 + length]
        if len(payload) != length:
            raise ValueError("truncated PNG chunk " + kind.decode("latin-1"))
        chunks.append((kind, payload))
        at += 12 + length
        if kind == b"IEND":
            break
    return chunks


def _paeth_row(row: np.ndarray, prior: np.ndarray, bpp: int) -> None:
    # Paeth depends on the pixel to the left, already decoded: one pass along the row.
    a = np.zeros(bpp, dtype=np.int16)
    c = np.zeros(bpp, dtype=np.int16)
    out = row.astype(np.int16)
    up = prior.astype(np.int16)
    for x in range(0, len(row), bpp):
        b = up[x:x + bpp]
        p = a + b - c
        pa, pb, pc = np.abs(p - a), np.abs(p - b), np.abs(p - c)
        predictor = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
        value = (out[x:x + bpp] + predictor) & 0xFF
        out[x:x + bpp] = value
        a, c = value, b
    row[:] = out.astype(np.uint8)


def _average_row(row: np.ndarray, prior: np.ndarray, bpp: int) -> None:
    out = row.astype(np.int32)
    up = prior.astype(np.int32)
    out[:bpp] = (out[:bpp] + (up[:bpp] >> 1)) & 0xFF
    for x in range(bpp, len(row)):
        out[x] = (out[x] + ((out[x - bpp] + up[x]) >> 1)) & 0xFF
    row[:] = out.astype(np.uint8)


def decode(data: bytes) -> np.ndarray:
    """A PNG file's pixels: uint8 (or big-endian 16-bit read as uint16) HxW or HxWxC."""
    width = height = depth = colour = 0
    compressed = bytearray()
    for kind, payload in _chunks(bytes(data)):
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", payload)
            if interlace:
                raise ValueError("interlaced PNG is not supported")
            if colour not in _CHANNELS or depth not in (8, 16):
                raise ValueError(f"PNG colour type {colour} at {depth} bits is not supported")
        elif kind == b"IDAT":
            compressed += payload
    if not width:
        raise ValueError("PNG without IHDR")
    channels = _CHANNELS[colour]
    bpp = channels * depth // 8
    stride = width * bpp
    raw = np.frombuffer(zlib.decompress(bytes(compressed)), dtype=np.uint8)
    if raw.size != height * (stride + 1):
        raise ValueError("PNG image data has the wrong length")
    rows = raw.reshape(height, stride + 1)
    filters = rows[:, 0]
    pixels = rows[:, 1:].copy()
    prior = np.zeros(stride, dtype=np.uint8)
    for y in range(height):
        row = pixels[y]
        kind = filters[y]
        if kind == 1:  # Sub: a running sum per byte of the pixel, modulo 256
            row[:] = np.add.accumulate(row.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
        elif kind == 2:  # Up
            row += prior
        elif kind == 3:
            _average_row(row, prior, bpp)
        elif kind == 4:
            _paeth_row(row, prior, bpp)
        elif kind != 0:
            raise ValueError(f"PNG filter type {kind} is not one of 0-4")
        prior = row
    if depth == 16:
        image = pixels.view(">u2").astype(np.uint16).reshape(height, width, channels)
    else:
        image = pixels.reshape(height, width, channels)
    return image[:, :, 0] if channels == 1 else image


def _chunk(kind: bytes, payload: bytes) -> bytes:
    return (struct.pack(">I", len(payload)) + kind + payload
            + struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))


def encode(image: np.ndarray, level: int = 6) -> bytes:
    """A PNG file of ``image``: uint8 HxW, HxWx3 or HxWx4, or uint16 HxW (16-bit grey).

    Rows use filter Up (vectorised, and usually smaller than none for rendered images).
    """
    array = np.asarray(image)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in (1, 3, 4):
        raise ValueError(f"a PNG is HxW, HxWx3 or HxWx4, not shape {image.shape}")
    height, width, channels = array.shape
    if array.dtype == np.uint8:
        depth = 8
        rows = np.ascontiguousarray(array).reshape(height, width * channels)
    elif array.dtype == np.uint16 and channels == 1:
        depth = 16
        rows = np.ascontiguousarray(array.astype(">u2")).view(np.uint8).reshape(height, width * 2)
    else:
        raise ValueError(f"PNG pixels are uint8, or uint16 grey; not {array.dtype} with "
                         f"{channels} channels")
    colour = {1: 0, 3: 2, 4: 6}[channels]
    filtered = np.empty((height, rows.shape[1] + 1), dtype=np.uint8)
    filtered[:, 0] = 2
    filtered[0, 0] = 0
    filtered[0, 1:] = rows[0]
    filtered[1:, 1:] = rows[1:] - rows[:-1]  # uint8 arithmetic wraps modulo 256, as PNG's
    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return (SIGNATURE + _chunk(b"IHDR", header)
            + _chunk(b"IDAT", zlib.compress(filtered.tobytes(), level)) + _chunk(b"IEND", b""))
