"""The one exception the client raises for an error answer: an RFC 9457 problem."""

from __future__ import annotations

import json
from typing import Any, Mapping, Optional

PROBLEM_TYPE_PREFIX = "https://myriad.dev/problems/"


class MyriadError(Exception):
    """An error answer of a Myriad server (or a transport failure), as an RFC 9457 problem.

    Attributes:
        status: the HTTP status (400, 404, 413, ...); 0 when no answer came (connection failed).
        type: the problem type URI, e.g. ``https://myriad.dev/problems/invalid-body``.
        name: the last segment of ``type`` (``"invalid-body"``): what code should branch on.
        title: the short English title of the type.
        detail: the sentence saying what went wrong in this request.
        pointer: the JSON Pointer of the body member to blame (``"/eye/1"``), or None.
        parameter: the query parameter to blame, or None.
        limit: the name of the limit exceeded (``"maxSessions"``), or None.
        retry_after: seconds from ``Retry-After`` (429, 503), or None.
        problem: the whole problem object as the server sent it.
        method, url: the request that failed.
    """

    def __init__(self, status: int, problem: Mapping[str, Any], *, method: str = "",
                 url: str = "", retry_after: Optional[float] = None) -> None:
        self.status = int(status)
        self.problem = dict(problem)
        self.type: str = str(problem.get("type", "about:blank"))
        self.title: str = str(problem.get("title", ""))
        self.detail: str = str(problem.get("detail", ""))
        self.pointer: Optional[str] = problem.get("pointer")
        self.parameter: Optional[str] = problem.get("parameter")
        self.limit: Optional[str] = problem.get("limit")
        self.retry_after = retry_after
        self.method = method
        self.url = url
        super().__init__(self._message())

    @property
    def name(self) -> str:
        """The problem type's name: ``type`` without ``https://myriad.dev/problems/``."""
        if self.type.startswith(PROBLEM_TYPE_PREFIX):
            return self.type[len(PROBLEM_TYPE_PREFIX):]
        return self.type

    def _message(self) -> str:
        where = f"{self.method} {self.url}: " if self.method else ""
        blame = ""
        if self.pointer is not None:
            blame = f" (pointer {self.pointer!r})"
        elif self.parameter is not None:
            blame = f" (parameter {self.parameter!r})"
        if self.limit is not None:
            blame += f" (limit {self.limit})"
        return f"{where}{self.status} {self.name}: {self.detail or self.title}{blame}"

    @classmethod
    def from_response(cls, status: int, content_type: str, body: bytes, *, method: str,
                      url: str, retry_after: Optional[str] = None) -> "MyriadError":
        """Builds the error from an answer; a body that is not a problem still gives one."""
        problem: Mapping[str, Any]
        try:
            parsed = json.loads(body.decode("utf-8")) if body else None
        except (UnicodeDecodeError, ValueError):
            parsed = None
        if isinstance(parsed, dict) and "type" in parsed:
            problem = parsed
        else:
            text = body[:200].decode("utf-8", "replace") if body else ""
            problem = {"type": "about:blank", "title": f"HTTP {status}",
                       "status": status,
                       "detail": f"The server answered {status} ({content_type or 'no body'})"
                                 + (f": {text}" if text else ".")}
        seconds: Optional[float] = None
        if retry_after:
            try:
                seconds = float(retry_after)
            except ValueError:
                seconds = None
        return cls(status, problem, method=method, url=url, retry_after=seconds)

    @classmethod
    def client_side(cls, detail: str, *, method: str = "", url: str = "",
                    name: str = "client-error") -> "MyriadError":
        """A failure found by the client itself (no answer, a malformed answer): status 0."""
        return cls(0, {"type": PROBLEM_TYPE_PREFIX + name, "title": "Client error",
                       "detail": detail}, method=method, url=url)
