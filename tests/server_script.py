"""What the Python CTests that drive a real myriad-server share (video_players_test.py,
deploy/batch_test.py): failures collected by check(), JSON requests, and a server started with
validation in a work directory, whose end is checked (exit 0 on SIGTERM) and whose log is shown
when something failed."""
import http.client
import json
import os
import re
import shutil
import subprocess
import tempfile
import time

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)
    return condition


def request(port, method, path, body=None, token=None, timeout=120, host="127.0.0.1"):
    """One request; `body` sent as JSON (an edit without one sends an empty body).
    Returns (status, headers, payload)."""
    c = http.client.HTTPConnection(host, port, timeout=timeout)
    headers = {}
    if token:
        headers["Authorization"] = "Bearer " + token
    data = None
    if body is not None:
        data = json.dumps(body).encode()
        headers["Content-Type"] = "application/json"
    elif method in ("POST", "PUT", "PATCH"):
        data = b""
    c.request(method, path, body=data, headers=headers)
    r = c.getresponse()
    payload = r.read()
    c.close()
    return r.status, dict(r.getheaders()), payload


class Server:
    """myriad-server on a free port with --validate, its stderr in WORK/server.log; `port` is None
    when it did not start (check() has said so). stop() ends it and removes WORK."""

    def __init__(self, binary, prefix, args=("--lights", "8")):
        self.started = time.monotonic()
        self.work = tempfile.mkdtemp(prefix=prefix)
        self.process = subprocess.Popen(
            [binary, "--host", "127.0.0.1", "--port", "0", *args, "--validate"],
            stdout=subprocess.PIPE, stderr=open(os.path.join(self.work, "server.log"), "wb"))
        m = re.search(r"listening on http://127\.0\.0\.1:(\d+)",
                      self.process.stdout.readline().decode())
        self.port = int(m.group(1)) if check(m is not None, "the server did not start") else None

    def stop(self):
        self.process.terminate()
        try:
            check(self.process.wait(30) == 0, "the server did not exit 0 on SIGTERM")
        except subprocess.TimeoutExpired:
            self.process.kill()
        if failures:
            with open(os.path.join(self.work, "server.log"), "rb") as f:
                print("--- server stderr (end) ---\n" + f.read()[-3000:].decode(errors="replace"))
        shutil.rmtree(self.work, ignore_errors=True)

    def verdict(self):
        return verdict(self.started)


def verdict(started):
    """The exit status of a test that began at `started` (time.monotonic()), after the time taken
    and PASS or the failure count."""
    print(f"total {time.monotonic() - started:.1f} s")
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("PASS")
    return 0
