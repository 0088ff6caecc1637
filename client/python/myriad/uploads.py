"""Request bodies for model, asset and environment uploads.

One argument names what to upload, in any of the forms ``PUT .../model`` takes
(protocol/reference.md "Model"):

- ``"builtin:default"`` or ``"library:NAME"``: JSON ``{"source": ...}``;
- a path (str or ``os.PathLike``) to a file: the file itself (``application/octet-stream`` with
  ``?filename=``), or a ``.zip`` archive (``application/zip``);
- a path to a directory: every file under it as ``multipart/form-data`` (each part's filename its
  path relative to the directory);
- ``bytes`` with ``filename=``: the file's bytes (a ``.zip`` name sends them as a zip);
- a mapping ``{relative path: bytes or path}`` or a list of paths: several files as multipart.
"""

from __future__ import annotations

import json
import os
import uuid
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Dict, List, Mapping, Optional, Sequence, Union

Source = Union[str, "os.PathLike[str]", bytes, bytearray, Mapping[str, Union[bytes, str,
                                                                               "os.PathLike[str]"]],
               Sequence[Union[str, "os.PathLike[str]"]]]

SOURCE_PREFIXES = ("builtin:", "library:")


@dataclass
class Body:
    """An encoded body: its bytes, Content-Type and the query it needs (filename)."""

    data: bytes
    content_type: str
    filename: Optional[str] = None


def _read(item: Union[bytes, bytearray, str, "os.PathLike[str]"]) -> bytes:
    if isinstance(item, (bytes, bytearray)):
        return bytes(item)
    return Path(item).read_bytes()


def multipart(files: Mapping[str, bytes]) -> Body:
    """``multipart/form-data`` with one file part per entry, field name ``files``."""
    boundary = "myriad-" + uuid.uuid4().hex
    chunks: List[bytes] = []
    for name, data in files.items():
        quoted = name.replace("\\", "\\\\").replace('"', '\\"')
        chunks.append(
            (f"--{boundary}\r\nContent-Disposition: form-data; name=\"files\"; "
             f"filename=\"{quoted}\"\r\nContent-Type: application/octet-stream\r\n\r\n")
            .encode("utf-8"))
        chunks.append(data)
        chunks.append(b"\r\n")
    chunks.append(f"--{boundary}--\r\n".encode("ascii"))
    return Body(b"".join(chunks), f"multipart/form-data; boundary={boundary}")


def directory_files(root: Path) -> Dict[str, bytes]:
    """Every file under ``root``, by its path relative to it (POSIX separators), sorted."""
    files: Dict[str, bytes] = {}
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        files[PurePosixPath(*path.relative_to(root).parts).as_posix()] = path.read_bytes()
    return files


def encode(source: Source, filename: Optional[str] = None) -> Body:
    """The body for one upload argument (see the module's docstring)."""
    if isinstance(source, str) and source.startswith(SOURCE_PREFIXES):
        if filename is not None:
            raise ValueError("filename goes with an upload, not with " + repr(source))
        return Body(json.dumps({"source": source}).encode("utf-8"), "application/json")
    if isinstance(source, (bytes, bytearray)):
        if not filename:
            raise ValueError("uploading bytes needs filename= (NAME.EXT: the extension names "
                             "the format)")
        kind = "application/zip" if filename.lower().endswith(".zip") else \
            "application/octet-stream"
        return Body(bytes(source), kind, filename)
    if isinstance(source, Mapping):
        return multipart({str(name): _read(item) for name, item in source.items()})
    if isinstance(source, (list, tuple)):
        return multipart({Path(item).name: _read(item) for item in source})
    path = Path(source)  # type: ignore[arg-type]
    if path.is_dir():
        files = directory_files(path)
        if not files:
            raise ValueError(f"the directory {path} holds no file to upload")
        return multipart(files)
    name = filename or path.name
    kind = "application/zip" if name.lower().endswith(".zip") else "application/octet-stream"
    return Body(path.read_bytes(), kind, name)
