"""HTTP/1.1 over the standard library: keep-alive, one connection per thread.

``http.client`` is enough here: the server speaks plain HTTP/1.1 with Content-Length or chunked
bodies, and a frame is one request and one answer. Each thread gets its own connection (an
``http.client.HTTPConnection`` is not thread-safe), so ``render_path`` keeps N requests in flight
over N connections. The server closes a kept-alive connection after 2 s without a request
(reference.md "Connections"): a request that meets a connection closed that way, before any answer
came, is sent once more on a new connection.
"""

from __future__ import annotations

import http.client
import json
import socket
import threading
import time
import urllib.parse
from dataclasses import dataclass
from typing import Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union

from .errors import MyriadError

QueryValue = Union[str, int, float, bool]
Query = Optional[Mapping[str, Optional[QueryValue]]]

# A kept-alive connection idle this long is not reused: the server closes it after 2 s, and a
# request sent as it closes may be lost without an answer.
_MAX_IDLE_SECONDS = 1.5


@dataclass
class Response:
    """One answer: status, headers (names lower-case) and the whole body."""

    status: int
    headers: Dict[str, str]
    body: Union[bytes, bytearray]

    def json(self) -> Any:
        return json.loads(self.body.decode("utf-8") if isinstance(self.body, (bytes, bytearray))
                          else self.body)

    def header(self, name: str, default: Optional[str] = None) -> Optional[str]:
        return self.headers.get(name.lower(), default)


def format_query(query: Query) -> str:
    """``{"target": "final,depth", "width": 64}`` -> ``target=final,depth&width=64``.

    Booleans are written ``true``/``false``; None values are left out; commas stay as they are
    (the server splits target lists on them).
    """
    if not query:
        return ""
    pairs: List[Tuple[str, str]] = []
    for key, value in query.items():
        if value is None:
            continue
        if isinstance(value, bool):
            text = "true" if value else "false"
        elif isinstance(value, float):
            text = repr(value)
        else:
            text = str(value)
        pairs.append((key, text))
    return urllib.parse.urlencode(pairs, safe=",", quote_via=urllib.parse.quote)


class _Slot:
    """A thread's connection and when it was last used."""

    def __init__(self) -> None:
        self.connection: Optional[http.client.HTTPConnection] = None
        self.last_used = 0.0


class Transport:
    """Requests to one server; thread-safe (a connection per thread)."""

    def __init__(self, url: str, *, authorization: Optional[str] = None,
                 timeout: float = 300.0) -> None:
        parsed = urllib.parse.urlsplit(url if "://" in url else "http://" + url)
        if parsed.scheme not in ("http", "https"):
            raise ValueError(f"the server URL must be http:// or https://, not {url!r}")
        if not parsed.hostname:
            raise ValueError(f"the server URL {url!r} names no host")
        self.scheme = parsed.scheme
        self.host = parsed.hostname
        self.port = parsed.port or (443 if parsed.scheme == "https" else 80)
        self.prefix = parsed.path.rstrip("/")
        self.base_url = f"{parsed.scheme}://{parsed.netloc}{self.prefix}"
        self.authorization = authorization
        self.timeout = timeout
        self._local = threading.local()
        self._lock = threading.Lock()
        self._connections: List[http.client.HTTPConnection] = []
        self._slots: List[Tuple[threading.Thread, _Slot]] = []

    # Connections ------------------------------------------------------------------------------

    def new_connection(self, timeout: Optional[float] = None) -> http.client.HTTPConnection:
        """A new connection, not shared with any thread (streams take one of their own)."""
        cls = http.client.HTTPSConnection if self.scheme == "https" else http.client.HTTPConnection
        connection = cls(self.host, self.port, timeout=self.timeout if timeout is None else timeout)
        with self._lock:
            self._connections.append(connection)
        return connection

    def _slot(self) -> _Slot:
        slot = getattr(self._local, "slot", None)
        if slot is None:
            self.prune()
            slot = _Slot()
            self._local.slot = slot
            with self._lock:
                self._slots.append((threading.current_thread(), slot))
        return slot

    def prune(self) -> None:
        """Closes the connections of threads that have ended (render_path's workers)."""
        with self._lock:
            ended = [slot for thread, slot in self._slots if not thread.is_alive()]
            self._slots = [(t, slot) for t, slot in self._slots if t.is_alive()]
        for slot in ended:
            self._drop(slot.connection)
            slot.connection = None

    def _drop(self, connection: Optional[http.client.HTTPConnection]) -> None:
        if connection is None:
            return
        connection.close()
        with self._lock:
            if connection in self._connections:
                self._connections.remove(connection)

    def close(self) -> None:
        """Closes every connection of every thread (they reconnect on their next request)."""
        with self._lock:
            connections, self._connections = self._connections, []
        for connection in connections:
            connection.close()

    # Requests ---------------------------------------------------------------------------------

    def url(self, path: str, query: Query = None) -> str:
        text = format_query(query)
        return self.prefix + path + ("?" + text if text else "")

    def request(self, method: str, path: str, *, query: Query = None,
                body: Optional[Union[bytes, bytearray, memoryview]] = None,
                content_type: Optional[str] = None, token: Optional[str] = None,
                headers: Optional[Mapping[str, str]] = None,
                ok: Iterable[int] = (200, 201, 204)) -> Response:
        """Sends one request on this thread's connection and reads the whole answer.

        Raises MyriadError for a status outside ``ok`` (the problem the server sent) and for a
        connection that fails (status 0).
        """
        target = self.url(path, query)
        send_headers = self._headers(token, headers, content_type, body)
        slot = self._slot()
        for attempt in (0, 1):
            reused = slot.connection is not None
            if reused and time.monotonic() - slot.last_used > _MAX_IDLE_SECONDS:
                self._drop(slot.connection)
                slot.connection, reused = None, False
            if slot.connection is None:
                slot.connection = self.new_connection()
            connection = slot.connection
            try:
                connection.request(method, target, body=body, headers=send_headers)
                answer = connection.getresponse()
            except (http.client.RemoteDisconnected, ConnectionResetError, BrokenPipeError,
                    http.client.CannotSendRequest, http.client.BadStatusLine) as error:
                self._drop(connection)
                slot.connection = None
                if reused and attempt == 0:
                    continue  # the server closed the idle connection: send again on a new one
                raise MyriadError.client_side(f"the connection failed: {error!r}", method=method,
                                              url=self.base_url + target,
                                              name="connection-failed") from error
            except (OSError, socket.timeout) as error:
                self._drop(connection)
                slot.connection = None
                raise MyriadError.client_side(f"the connection failed: {error!r}", method=method,
                                              url=self.base_url + target,
                                              name="connection-failed") from error
            try:
                response = self._read(answer)
            except (OSError, http.client.HTTPException) as error:
                self._drop(connection)
                slot.connection = None
                raise MyriadError.client_side(f"the answer was cut off: {error!r}",
                                              method=method, url=self.base_url + target,
                                              name="connection-failed") from error
            if answer.will_close:
                self._drop(connection)
                slot.connection = None
            slot.last_used = time.monotonic()
            if response.status not in ok:
                raise MyriadError.from_response(
                    response.status, response.header("content-type", "") or "",
                    bytes(response.body), method=method, url=self.base_url + target,
                    retry_after=response.header("retry-after"))
            return response
        raise AssertionError("unreachable")

    def open(self, method: str, path: str, *, query: Query = None, token: Optional[str] = None,
             headers: Optional[Mapping[str, str]] = None,
             timeout: Optional[float] = None) -> Tuple[http.client.HTTPConnection,
                                                      http.client.HTTPResponse]:
        """Starts a request on a connection of its own and returns it unread (streams).

        The caller reads the body and closes the connection. An error status raises MyriadError.
        """
        target = self.url(path, query)
        connection = self.new_connection(timeout)
        try:
            connection.request(method, target, headers=self._headers(token, headers, None, None))
            answer = connection.getresponse()
        except (OSError, http.client.HTTPException) as error:
            self._drop(connection)
            raise MyriadError.client_side(f"the connection failed: {error!r}", method=method,
                                          url=self.base_url + target,
                                          name="connection-failed") from error
        if answer.status != 200:
            body = answer.read()
            self._drop(connection)
            raise MyriadError.from_response(answer.status, answer.getheader("content-type", ""),
                                            body, method=method, url=self.base_url + target,
                                            retry_after=answer.getheader("retry-after"))
        return connection, answer

    def forget(self, connection: http.client.HTTPConnection) -> None:
        """Closes a connection ``open`` returned."""
        self._drop(connection)

    def _headers(self, token: Optional[str], extra: Optional[Mapping[str, str]],
                 content_type: Optional[str], body: Any) -> Dict[str, str]:
        headers: Dict[str, str] = {"Accept-Encoding": "identity"}
        bearer = token or self.authorization
        if bearer:
            headers["Authorization"] = "Bearer " + bearer
        if content_type:
            headers["Content-Type"] = content_type
        if body is not None:
            headers["Content-Length"] = str(len(body))
        if extra:
            headers.update(extra)
        return headers

    @staticmethod
    def _read(answer: http.client.HTTPResponse) -> Response:
        headers = {name.lower(): value for name, value in answer.getheaders()}
        length = answer.getheader("content-length")
        body: Union[bytes, bytearray]
        if length is not None and not answer.chunked:
            # Read into a bytearray so numpy arrays over frames are writable without a copy.
            size = int(length)
            body = bytearray(size)
            view = memoryview(body)
            done = 0
            while done < size:
                n = answer.readinto(view[done:])
                if not n:
                    raise http.client.IncompleteRead(bytes(view[:done]), size - done)
                done += n
            answer.read()  # lets http.client see the end of the answer
        else:
            body = answer.read()
        return Response(answer.status, headers, body)
