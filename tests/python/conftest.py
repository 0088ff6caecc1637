"""Fixtures: a real myriad-server (lavapipe, Vulkan validation on), a client, sessions, models.

The server binary is $MYRIAD_SERVER (the CTest sets it), else the first build found. It runs as
the C++ API tests run it (tests/server_process.cpp): --port 0 --host 127.0.0.1 --validate, a small
light count; at the end GET /v1/info must count 0 validation messages, its stderr must hold no
"[vulkan-validation]" line, and SIGTERM must end it with status 0.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Iterator, List

import pytest

import myriad

REPO = Path(__file__).resolve().parents[2]
SERVER_CANDIDATES = ["build/release/server/myriad-server", "build/server/myriad-server",
                     "build/debug/server/myriad-server"]
# Lights of the server's built-in scene: few, so that frames on lavapipe take milliseconds.
LIGHTS = 16
MAX_LIGHTS = 5000


def server_path() -> str:
    explicit = os.environ.get("MYRIAD_SERVER")
    if explicit:
        return explicit
    for candidate in SERVER_CANDIDATES:
        if (REPO / candidate).is_file():
            return str(REPO / candidate)
    pytest.exit("no myriad-server: set MYRIAD_SERVER or build the myriad-server target", 2)


class ServerProcess:
    """A myriad-server started for the tests, with its URL and its stderr."""

    def __init__(self, extra: List[str]) -> None:
        self.stderr_file = tempfile.NamedTemporaryFile(prefix="myriad-py-stderr-", delete=False)
        args = [server_path(), "--port", "0", "--host", "127.0.0.1", "--validate",
                "--lights", str(LIGHTS), "--max-lights", str(MAX_LIGHTS), *extra]
        self.process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.stderr_file,
                                        stdin=subprocess.DEVNULL)
        self.url = self._wait_for_url(60.0)

    def _wait_for_url(self, seconds: float) -> str:
        deadline = time.monotonic() + seconds
        seen = b""
        assert self.process.stdout is not None
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.process.stdout], [], [], 0.5)
            if ready:
                chunk = os.read(self.process.stdout.fileno(), 4096)
                if not chunk:
                    break
                seen += chunk
                if b"http://" in seen and b"\n" in seen[seen.index(b"http://"):]:
                    start = seen.index(b"http://")
                    return seen[start:seen.index(b"\n", start)].decode().strip()
        self.process.kill()
        raise RuntimeError(f"myriad-server did not print its URL; stderr: {self.stderr()[:2000]}")

    def stderr(self) -> str:
        return Path(self.stderr_file.name).read_text(errors="replace")

    def stop(self) -> int:
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.process.wait()

    def close(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        os.unlink(self.stderr_file.name)


@pytest.fixture(scope="session")
def server() -> Iterator[ServerProcess]:
    process = ServerProcess([])
    try:
        yield process
        # Every test ran against this server with validation on: not one message.
        info = myriad.Client(process.url).info()
        assert info["validation"]["messages"] == 0, process.stderr()[-4000:]
        assert process.stop() == 0, process.stderr()[-4000:]
        assert "[vulkan-validation]" not in process.stderr()
    finally:
        process.close()


@pytest.fixture(autouse=True)
def server_alive(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fails a test (and every later one) with the server's status and stderr once it died."""
    if "server" not in request.fixturenames:
        yield
        return
    process: ServerProcess = request.getfixturevalue("server")
    if process.process.poll() is not None:
        pytest.fail(f"myriad-server had already exited ({process.process.returncode}); its "
                    f"stderr ends: {process.stderr()[-3000:]}")
    yield
    if process.process.poll() is not None:
        pytest.fail(f"myriad-server exited ({process.process.returncode}) during this test; its "
                    f"stderr ends: {process.stderr()[-3000:]}")


@pytest.fixture(scope="session")
def client(server: ServerProcess) -> Iterator[myriad.Client]:
    with myriad.Client(server.url) as c:
        yield c


@pytest.fixture
def session(client: myriad.Client) -> Iterator[myriad.Session]:
    with client.session() as s:
        yield s


# A unit cube as Wavefront OBJ with its material file: small models the tests upload as bytes,
# as a zip, as several files and as a directory.
CUBE_MTL = b"newmtl red\nKd 0.8 0.1 0.1\nNs 10\n"
CUBE_OBJ = b"""mtllib cube.mtl
v -0.5 0 -0.5
v 0.5 0 -0.5
v 0.5 1 -0.5
v -0.5 1 -0.5
v -0.5 0 0.5
v 0.5 0 0.5
v 0.5 1 0.5
v -0.5 1 0.5
usemtl red
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 4 8 7 3
f 1 5 8 4
f 2 3 7 6
"""
# The same cube without a material file: one self-contained file.
PLAIN_CUBE_OBJ = b"\n".join(line for line in CUBE_OBJ.split(b"\n")
                            if not line.startswith((b"mtllib", b"usemtl"))) + b"\n"


def radiance_hdr(width: int = 4, height: int = 2) -> bytes:
    """A tiny flat (not run-length encoded) Radiance .hdr of a grey sky."""
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode("ascii")
    return header + bytes([128, 128, 128, 129]) * (width * height)
