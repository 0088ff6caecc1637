"""Readers of the server's long answers: the image stream (multipart/x-mixed-replace) and the
event stream (text/event-stream). Each holds a connection of its own while it is read."""

from __future__ import annotations

import http.client
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Dict, Iterator, Optional

import numpy as np

from .errors import MyriadError
from .frames import decode_image

if TYPE_CHECKING:
    from .client import Session

BOUNDARY = b"--myriad-frame"


@dataclass
class StreamFrame:
    """One part of an image stream.

    Attributes:
        sequence: its X-Myriad-Frame number (a re-send of an unchanged scene repeats it).
        content_type: ``image/jpeg`` or ``image/png``.
        data: the encoded image.
        image: uint8 HxWx3 RGB (None when the stream was opened with ``decode=False``).
        interactive: the render scale of an interactive part (X-Myriad-Interactive), else None.
    """

    sequence: int
    content_type: str
    data: bytes
    image: Optional[np.ndarray] = None
    interactive: Optional[float] = None
    headers: Dict[str, str] = field(default_factory=dict)


def _read_line(answer: http.client.HTTPResponse) -> bytes:
    line = answer.readline(65536)
    if not line:
        raise EOFError
    return line


def _part_headers(answer: http.client.HTTPResponse) -> Dict[str, str]:
    headers: Dict[str, str] = {}
    while True:
        line = _read_line(answer).rstrip(b"\r\n")
        if not line:
            return headers
        name, _, value = line.decode("latin-1").partition(":")
        headers[name.strip().lower()] = value.strip()


def image_stream(session: "Session", query: Dict[str, Any], max_frames: Optional[int],
                 decode: bool) -> Iterator[StreamFrame]:
    transport = session.client.transport
    path = session._path("/stream")
    connection, answer = transport.open("GET", path, query=query, token=session.token)
    count = 0
    try:
        while max_frames is None or count < max_frames:
            try:
                line = _read_line(answer).rstrip(b"\r\n")
                if not line:
                    continue
                if line == BOUNDARY + b"--":
                    return
                if line != BOUNDARY:
                    raise MyriadError.client_side(f"the stream's body has {line[:40]!r} where "
                                                  "its boundary belongs",
                                                  name="malformed-answer")
                headers = _part_headers(answer)
                length = int(headers.get("content-length", "-1"))
                if length < 0:
                    raise MyriadError.client_side("a stream part without Content-Length",
                                                  name="malformed-answer")
                data = answer.read(length)
                if len(data) != length:
                    raise EOFError
            except EOFError:
                return  # the server ended the stream without saying why (shutdown, replaced)
            kind = headers.get("content-type", "")
            if kind.startswith("application/problem+json"):
                raise MyriadError.from_response(
                    int(json.loads(data.decode("utf-8")).get("status", 0)), kind, data,
                    method="GET", url=transport.base_url + path)
            part = StreamFrame(sequence=int(headers.get("x-myriad-frame", "0")),
                               content_type=kind, data=data, headers=headers)
            if "x-myriad-interactive" in headers:
                part.interactive = float(headers["x-myriad-interactive"])
            if decode:
                part.image = decode_image(data)
            count += 1
            yield part
    finally:
        transport.forget(connection)


def event_stream(session: "Session", max_events: Optional[int]) -> Iterator[Dict[str, Any]]:
    transport = session.client.transport
    connection, answer = transport.open("GET", session._path("/events"), token=session.token)
    count = 0
    try:
        event = "message"
        data: list = []
        while max_events is None or count < max_events:
            line = answer.readline(65536)
            if not line:
                return
            text = line.decode("utf-8").rstrip("\r\n")
            if text.startswith(":"):
                continue  # a keep-alive comment
            if text:
                name, _, value = text.partition(":")
                value = value[1:] if value.startswith(" ") else value
                if name == "event":
                    event = value
                elif name == "data":
                    data.append(value)
                continue
            if not data:
                continue
            payload = json.loads("\n".join(data))
            message = {"event": event, **(payload if isinstance(payload, dict) else
                                          {"data": payload})}
            count += 1
            yield message
            if event == "end":
                return
            event, data = "message", []
    finally:
        transport.forget(connection)
