"""Which HTTP routes each public client method uses.

Every public method of :class:`myriad.Client` and :class:`myriad.Session` is decorated with
:func:`route`, naming the operations of the server's OpenAPI document (``GET /v1/openapi.json``)
it calls. The test suite checks each against the document, and that every session route the
document lists is wrapped by some method.
"""

from __future__ import annotations

from typing import Callable, Dict, List, Tuple, TypeVar

F = TypeVar("F", bound=Callable[..., object])

# (method, route template as in the OpenAPI document's paths)
Route = Tuple[str, str]


def route(*routes: str) -> Callable[[F], F]:
    """Marks a method with the routes it calls, each written ``"GET /v1/sessions/{id}"``."""
    parsed: List[Route] = []
    for text in routes:
        method, _, template = text.partition(" ")
        if not method.isupper() or not template.startswith("/"):
            raise ValueError(f"a route is written 'METHOD /path', not {text!r}")
        parsed.append((method, template))

    def mark(function: F) -> F:
        function.__myriad_routes__ = tuple(parsed)  # type: ignore[attr-defined]
        return function

    return mark


def routes_of(cls: type) -> Dict[str, Tuple[Route, ...]]:
    """Public method name -> the routes it is marked with (empty for unmarked ones)."""
    table: Dict[str, Tuple[Route, ...]] = {}
    for name in dir(cls):
        if name.startswith("_"):
            continue
        member = getattr(cls, name)
        if callable(member):
            table[name] = getattr(member, "__myriad_routes__", ())
    return table
