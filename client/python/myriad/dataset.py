"""A dataset on disk from frames: images, arrays and one metadata.json.

The layout (the server's batch mode writes the same)::

    DIR/metadata.json
    DIR/final_00000.png          8-bit sRGB RGB
    DIR/depth_00000.npy          float32 HxW (and depth_00000.exr when OpenEXR is importable)
    DIR/normal_00000.npy         float32 HxWx3 (and .exr likewise)
    DIR/instance-id_00000.png    16-bit grey: the object id (semantic-id, material-id alike)
    DIR/<target>_00000.npy       any other float target

``metadata.json``::

    {"format": "myriad-dataset", "version": 1,
     "frames": [{"index": 0, "time": null, "width": 320, "height": 240,
                 "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
                 "world_from_camera": [[...4], [...4], [...4], [0, 0, 0, 1]],
                 "near": 0.1, "far": 100.0,
                 "files": {"final": "final_00000.png", "depth": "depth_00000.npy", ...}}]}

``K`` is OpenCV's pinhole matrix in pixels and ``world_from_camera`` maps camera space (x right,
y down, z forward) to the world, as :class:`myriad.Frame` documents them. Files are named
``<target>_<index, 5 digits>.<ext>``; metadata.json is written (atomically) when the writer
closes, listing the frames in the order they were written.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Union

import numpy as np

from . import png
from .frames import IMAGE_TARGETS, LABEL_TARGETS, Frame

try:  # EXR beside .npy only where an OpenEXR Python module exists (Debian 12 has none)
    import OpenEXR as _OpenEXR  # type: ignore[import-not-found]
except ImportError:  # pragma: no cover - depends on the machine
    _OpenEXR = None

FORMAT = "myriad-dataset"
VERSION = 1
# Float targets also written as EXR when OpenEXR is importable.
EXR_TARGETS = ("depth", "normal")


def file_name(target: str, index: int, extension: str) -> str:
    """``final``, 3, ``png`` -> ``final_00003.png``."""
    return f"{target}_{index:05d}.{extension}"


def _atomic_write(path: Path, data: bytes) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix="." + path.name + ".")
    try:
        with os.fdopen(handle, "wb") as out:
            out.write(data)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def _write_exr(path: Path, array: np.ndarray) -> None:  # pragma: no cover - needs OpenEXR
    channels = {"Y": array} if array.ndim == 2 else {
        name: array[:, :, i] for i, name in enumerate("RGBA"[:array.shape[2]])}
    header = {"compression": _OpenEXR.ZIP_COMPRESSION, "type": _OpenEXR.scanlineimage}
    with _OpenEXR.File(header, {name: np.ascontiguousarray(c, dtype=np.float32)
                                for name, c in channels.items()}) as exr:
        exr.write(str(path))


class Writer:
    """Writes frames into a dataset directory; a context manager (metadata.json on exit).

    Args:
        directory: where the files go (made if missing).
        exr: also write EXR for depth and normal: None (default) when OpenEXR is importable,
            True to require it, False never.
    """

    def __init__(self, directory: Union[str, "os.PathLike[str]"],
                 exr: Optional[bool] = None) -> None:
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        if exr and _OpenEXR is None:
            raise RuntimeError("EXR output needs an OpenEXR Python module, which is not "
                               "importable here")
        self.exr = (_OpenEXR is not None) if exr is None else exr
        self.frames: List[Dict[str, Any]] = []
        self._next_index = 0

    def __enter__(self) -> "Writer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def write(self, frame: Frame, index: Optional[int] = None) -> Dict[str, Any]:
        """Writes one frame's targets; returns its metadata entry. ``index`` defaults to the
        frame's own (``render_path`` sets it), else one more than the last written."""
        if index is None:
            index = frame.index if frame.index is not None else self._next_index
        self._next_index = index + 1
        files: Dict[str, str] = {}
        for target, array in frame.items():
            if target in IMAGE_TARGETS:
                name = file_name(target, index, "png")
                _atomic_write(self.directory / name, png.encode(array, level=1))
            elif target in LABEL_TARGETS:
                if array.size and int(array.max()) > 0xFFFF:
                    raise ValueError(f"{target} of frame {index} holds {int(array.max())}, more "
                                     "than a 16-bit PNG holds")
                name = file_name(target, index, "png")
                _atomic_write(self.directory / name, png.encode(array.astype(np.uint16),
                                                                level=1))
            else:
                name = file_name(target, index, "npy")
                buffer = io.BytesIO()
                np.save(buffer, np.ascontiguousarray(array), allow_pickle=False)
                _atomic_write(self.directory / name, buffer.getvalue())
                if self.exr and target in EXR_TARGETS:
                    exr_name = file_name(target, index, "exr")
                    _write_exr(self.directory / exr_name, array)
                    files[target + ".exr"] = exr_name
            files[target] = name
        entry = {"index": index, "time": frame.time, "width": frame.width,
                 "height": frame.height, "K": frame.K.tolist(),
                 "world_from_camera": frame.world_from_camera.tolist(), "near": frame.near,
                 "far": frame.far, "files": files}
        self.frames.append(entry)
        return entry

    def close(self) -> Path:
        """Writes DIR/metadata.json (atomically) and returns its path."""
        path = self.directory / "metadata.json"
        document = {"format": FORMAT, "version": VERSION, "frames": self.frames}
        _atomic_write(path, json.dumps(document, indent=1).encode("utf-8"))
        return path


def write(frames: Iterable[Frame], directory: Union[str, "os.PathLike[str]"],
          exr: Optional[bool] = None) -> Path:
    """Writes every frame of ``frames`` (e.g. ``session.render_path(...)``) into ``directory``;
    returns the path of its metadata.json. Frames are written as they come (bounded memory)."""
    with Writer(directory, exr=exr) as writer:
        for frame in frames:
            writer.write(frame)
    return writer.directory / "metadata.json"


def read_metadata(directory: Union[str, "os.PathLike[str]"]) -> Dict[str, Any]:
    """DIR/metadata.json, checked to be a myriad-dataset of a version this package reads."""
    document = json.loads((Path(directory) / "metadata.json").read_text())
    if document.get("format") != FORMAT or document.get("version") != VERSION:
        raise ValueError(f"{directory} is not a {FORMAT} version {VERSION}")
    return document
