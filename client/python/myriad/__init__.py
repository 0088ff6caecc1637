"""Myriad's Python client: a remote Myriad renderer's frames as numpy arrays.

    import myriad
    client = myriad.Client("http://127.0.0.1:8080")
    with client.session() as session:
        frame = session.frame(["final", "depth", "normal"], width=640, height=360)
        rgb, depth, normal = frame["final"], frame["depth"], frame["normal"]

See README.md beside this package, and protocol/reference.md for the HTTP API it wraps.
"""

from .client import Client, Session
from .errors import MyriadError
from .frames import Frame
from .stream import StreamFrame

__all__ = ["Client", "Session", "MyriadError", "Frame", "StreamFrame"]
__version__ = "0.1.0"
