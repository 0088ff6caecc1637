"""Frames as numpy arrays: the :class:`Frame` type and the decoders of the server's formats.

Every target of a Frame is a numpy array with a fixed dtype and shape:

================================  ============  ===========  ==================================
target                            dtype         shape        values
================================  ============  ===========  ==================================
``final``                         uint8         H x W x 3    sRGB, tonemapped (the PNG's RGB)
``depth``                         float32       H x W        metres along the view axis (or to
                                                             the camera with ``depth="distance"``)
``normal``, ``position``,         float32       H x W x 3    world space (camera space with
``albedo``, ``emissive``, ...                                ``space="camera"``), linear colour
``uv``                            float32       H x W x 2
``shadow``                        float32       H x W x 2    the sun's shadow factor (1 lit),
                                                             its cascade (-1: no surface)
``metallic``, ``roughness``,      float32       H x W
``occlusion``, ``light-count``
``instance-id``, ``semantic-id``, uint32        H x W        object id / class / material id
``material-id``
================================  ============  ===========  ==================================

Rows are top first (row 0 is the top of the image), as the server sends them.
"""

from __future__ import annotations

import ast
import io
import json
import struct
import zlib
from typing import Any, Dict, Iterator, List, Mapping, Optional

import numpy as np

from . import png
from .errors import MyriadError

try:  # Pillow decodes PNG and JPEG faster than the package's own reader (PNG only)
    from PIL import Image as _PILImage
except ImportError:  # pragma: no cover - depends on the machine
    _PILImage = None

# The label targets: raw frames of these are uint32 (X-Myriad-Dtype).
LABEL_TARGETS = ("instance-id", "semantic-id", "material-id")
# Targets that are 8-bit sRGB pictures in a Frame (read from PNG; raw would be linear HDR).
IMAGE_TARGETS = ("final",)


class Frame(Mapping[str, np.ndarray]):
    """One rendered frame: a read-only mapping target -> numpy array, and its camera.

    Attributes:
        K: 3x3 float64 pinhole intrinsics in pixels (OpenCV's convention: a camera-space point
            ``(x, y, z)`` lands at ``u = fx x / z + cx``, ``v = fy y / z + cy``; (0, 0) is the
            top-left corner of the top-left pixel).
        world_from_camera: 4x4 float64 rigid transform from camera space (x right, y down,
            z forward) to world space; its last column is the eye.
        near, far: the camera's clip distances (raw depth is ``far`` where nothing is).
        width, height: the image size in pixels.
        time: the animation time asked for, else the one the server says it showed
            (X-Myriad-Time), else None.
        version: the session version the frame shows, when the server says it (else None).
        index: the frame's position in a ``render_path`` (else None).
        camera: the camera body it was rendered with, when given (``render_path``).
        headers: the answer's headers (of the first request when several made the frame).
    """

    def __init__(self, arrays: Dict[str, np.ndarray], *, K: np.ndarray,
                 world_from_camera: np.ndarray, near: float, far: float, width: int,
                 height: int, time: Optional[float] = None, version: Optional[int] = None,
                 index: Optional[int] = None, camera: Optional[Mapping[str, Any]] = None,
                 headers: Optional[Mapping[str, str]] = None) -> None:
        self._arrays = dict(arrays)
        self.K = K
        self.world_from_camera = world_from_camera
        self.near = near
        self.far = far
        self.width = width
        self.height = height
        self.time = time
        self.version = version
        self.index = index
        self.camera = dict(camera) if camera is not None else None
        self.headers = dict(headers or {})

    def __getitem__(self, target: str) -> np.ndarray:
        try:
            return self._arrays[target]
        except KeyError:
            raise KeyError(f"this frame has no target {target!r}; it has "
                           f"{', '.join(self._arrays)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __repr__(self) -> str:
        parts = ", ".join(f"{t}: {a.dtype}{list(a.shape)}" for t, a in self._arrays.items())
        return f"<Frame {self.width}x{self.height} index={self.index} {{{parts}}}>"

    @property
    def intrinsics(self) -> Dict[str, float]:
        """fx, fy, cx, cy, width, height, near, far as X-Myriad-Intrinsics says them."""
        return {"fx": float(self.K[0, 0]), "fy": float(self.K[1, 1]), "cx": float(self.K[0, 2]),
                "cy": float(self.K[1, 2]), "width": self.width, "height": self.height,
                "near": self.near, "far": self.far}


class Camera:
    """What the X-Myriad-Intrinsics and X-Myriad-Pose headers say, as arrays."""

    def __init__(self, headers: Mapping[str, str]) -> None:
        intrinsics_text = headers.get("x-myriad-intrinsics")
        pose_text = headers.get("x-myriad-pose")
        if not intrinsics_text or not pose_text:
            raise MyriadError.client_side(
                "the frame's answer lacks X-Myriad-Intrinsics or X-Myriad-Pose",
                name="malformed-answer")
        intrinsics = json.loads(intrinsics_text)
        self.K = np.array([[intrinsics["fx"], 0.0, intrinsics["cx"]],
                           [0.0, intrinsics["fy"], intrinsics["cy"]],
                           [0.0, 0.0, 1.0]], dtype=np.float64)
        self.world_from_camera = np.array(json.loads(pose_text)["worldFromCamera"],
                                          dtype=np.float64)
        self.near = float(intrinsics["near"])
        self.far = float(intrinsics["far"])
        self.width = int(intrinsics["width"])
        self.height = int(intrinsics["height"])
        version = headers.get("x-myriad-version")
        self.version = int(version) if version is not None and version.isdigit() else None
        time = headers.get("x-myriad-time")  # the animation time shown, on servers that say it
        try:
            self.time: Optional[float] = float(time) if time is not None else None
        except ValueError:
            self.time = None


def decode_raw(body: Any, headers: Mapping[str, str]) -> np.ndarray:
    """A ``format=raw`` answer as an array: float32 or uint32, HxW (one channel) or HxWxC.

    ``body`` may be a bytearray (the array is then writable and shares its memory).
    """
    try:
        width = int(headers["x-myriad-width"])
        height = int(headers["x-myriad-height"])
        channels = len(headers["x-myriad-channels"].split(","))
    except (KeyError, ValueError) as error:
        raise MyriadError.client_side(f"a raw frame's answer lacks its X-Myriad-Width, -Height "
                                      f"or -Channels header ({error!r})",
                                      name="malformed-answer") from error
    dtype = {"float32": "<f4", "uint32": "<u4"}.get(headers.get("x-myriad-dtype", "float32"))
    if dtype is None:
        raise MyriadError.client_side(f"unknown X-Myriad-Dtype {headers.get('x-myriad-dtype')!r}",
                                      name="malformed-answer")
    expected = width * height * channels * 4
    if len(body) != expected:
        raise MyriadError.client_side(f"a raw {width}x{height}x{channels} frame is {expected} "
                                      f"bytes, the answer has {len(body)}",
                                      name="malformed-answer")
    array = np.frombuffer(body, dtype=dtype).reshape(height, width, channels)
    native = np.dtype(np.float32 if dtype == "<f4" else np.uint32)
    if array.dtype != native:  # a big-endian host: swap into native order
        array = array.astype(native)
    return array[:, :, 0] if channels == 1 else array


def decode_image(body: Any) -> np.ndarray:
    """A PNG or JPEG frame as uint8 HxWx3 (RGB; a PNG's alpha is dropped)."""
    data = bytes(body)
    if _PILImage is not None:
        with _PILImage.open(io.BytesIO(data)) as image:
            return np.asarray(image.convert("RGB"))
    if data[:8] != png.SIGNATURE:
        raise MyriadError.client_side("decoding a JPEG needs Pillow (Debian: python3-pil); "
                                      "ask for format='png' or install it", name="no-decoder")
    pixels = png.decode(data)
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[:, :, None], 3, axis=2)
    return np.ascontiguousarray(pixels[:, :, :3])


def _stored_npz(body: Any) -> Optional[Dict[str, np.ndarray]]:
    """The members of an npz whose members are all stored (not deflated), as arrays over the
    body's own memory (no copy: a bytearray body gives writable arrays). None for any other zip
    (deflated members, data descriptors, Zip64, Fortran order), which np.load then reads."""
    view = memoryview(body)
    members: Dict[str, np.ndarray] = {}
    at = 0
    while at + 30 <= len(view) and bytes(view[at:at + 4]) == b"PK\x03\x04":
        (flags, method, crc, compressed, size, name_length,
         extra_length) = struct.unpack_from("<2xHH4xIIIHH", view, at + 4)
        if method != 0 or flags & 0x8 or compressed != size or size == 0xFFFFFFFF:
            return None
        name = bytes(view[at + 30:at + 30 + name_length]).decode("utf-8")
        start = at + 30 + name_length + extra_length
        data = view[start:start + size]
        if len(data) != size or zlib.crc32(data) != crc or not name.endswith(".npy"):
            return None
        array = _npy_over(body, start, size)
        if array is None:
            return None
        members[name[:-4]] = array
        at = start + size
    return members if members else None


def _npy_over(body: Any, start: int, size: int) -> Optional[np.ndarray]:
    """The .npy file at body[start:start + size] as an array sharing its memory, or None."""
    head = bytes(memoryview(body)[start:start + min(size, 4096)])
    if head[:6] != b"\x93NUMPY":
        return None
    if head[6] == 1:
        (length,) = struct.unpack_from("<H", head, 8)
        offset = 10 + length
    else:
        (length,) = struct.unpack_from("<I", head, 8)
        offset = 12 + length
    try:
        header = ast.literal_eval(head[offset - length:offset].decode("latin-1"))
        dtype = np.dtype(header["descr"])
    except (ValueError, SyntaxError, KeyError, TypeError):
        return None
    shape = tuple(header["shape"])
    if header.get("fortran_order") or dtype.hasobject:
        return None
    count = int(np.prod(shape)) if shape else 1
    if offset + count * dtype.itemsize != size:
        return None
    array = np.frombuffer(body, dtype=dtype, count=count, offset=start + offset).reshape(shape)
    if not dtype.isnative:
        array = array.astype(dtype.newbyteorder("="))
    return array


def decode_npz(body: Any, targets: List[str]) -> Dict[str, np.ndarray]:
    """A ``format=npz`` answer: one ``<target>.npy`` per target (``K`` and
    ``world_from_camera`` too). Returns every member by name (without ``.npy``).

    The server stores its members uncompressed, so they are read in place (no copy); any other
    npz goes through numpy.load."""
    members = _stored_npz(body)
    if members is None:
        with np.load(io.BytesIO(bytes(body)), allow_pickle=False) as archive:
            members = {name: archive[name] for name in archive.files}
    missing = [t for t in targets if t not in members]
    if missing:
        raise MyriadError.client_side(f"the npz answer lacks {', '.join(missing)}",
                                      name="malformed-answer")
    return members


def as_frame_array(target: str, array: np.ndarray) -> np.ndarray:
    """Normalises an array of an npz answer to the dtype and shape a Frame documents."""
    if target in IMAGE_TARGETS:
        if array.dtype != np.uint8:
            raise MyriadError.client_side(f"npz {target} is {array.dtype}, not 8-bit sRGB",
                                          name="malformed-answer")
        return np.ascontiguousarray(array[:, :, :3]) if array.ndim == 3 else array
    if array.ndim == 3 and array.shape[2] == 1:
        return array[:, :, 0]
    return array
