#!/usr/bin/env python3
"""Hostile or slow video players (issue 35) against a real myriad-server, with raw sockets:

  0. A watcher: session W animates; its VP9 stream (Myriad's chunks, 160x96 at 10 fps) is read
     continuously by a thread that counts the pictures (key and delta chunks) it gets. Its rate
     before anything hostile happens is the baseline.
  1. A reader that stops: session A's VP9 stream (320x192, 20 Mbit/s asked, so it fills buffers
     fast) through a socket with a 4 KiB receive buffer that reads the response head and then
     nothing. The server must end the stream (kStreamWriteStall) and free its encoder:
     myriad_video_encoders_freed_total goes up, myriad_streams comes back.
  2. A reader that takes one byte a second: the same on session B. The same must happen (one byte
     a second does not open a TCP window: the server sees no progress).
  3. 100 streams of session C opened and dropped one after another (each: the request, the
     response head, close), each with its own bitrate and so its own channel. Every one is
     answered 200 (a place held by a client that hung up is given back); at most 100 encoders
     are made (none for a client seen gone before its first encode), and afterwards every
     encoder made is freed but the watcher's.

Throughout, the server's thread count and RSS (/proc/PID/status) are sampled: the thread count
never exceeds the baseline by more than the open streams could add, and is back at the baseline
at the end; RSS grows by less than 96 MiB. The watcher keeps at least 70% of its baseline rate
during each phase (2 shared cores, lavapipe: not an exact rate). The encoder pool's metrics are
looked at too: threads as asked (--encode-threads 2), queue depth back to 0, encodes counted in
myriad_encode_seconds. Bounded: the test < 60 s.

Usage: hostile_players_test.py MYRIAD_SERVER. Exit 0 pass, 1 fail.
"""
import json
import os
import re
import socket
import struct
import sys
import threading
import time

from server_script import Server, check, request

ENCODE_THREADS = 2
MAX_STREAMS = 8
WATCH_FPS = 10


def metrics(port):
    """Unlabelled samples of GET /metrics as {name: float}, and the labelled ones' text."""
    status, _, body = request(port, "GET", "/metrics", timeout=20)
    check(status == 200, f"GET /metrics -> {status}")
    values = {}
    for line in body.decode().splitlines():
        m = re.match(r"^([a-z_]+)(\{[^}]*\})? (\S+)$", line)
        if m:
            values[m.group(1) + (m.group(2) or "")] = float(m.group(3))
    return values


def proc_status(pid):
    """(threads, RSS in KiB) of process `pid`."""
    with open(f"/proc/{pid}/status") as f:
        text = f.read()
    threads = int(re.search(r"^Threads:\s+(\d+)", text, re.M).group(1))
    rss = int(re.search(r"^VmRSS:\s+(\d+)", text, re.M).group(1))
    return threads, rss


def new_session(port):
    status, _, body = request(port, "POST", "/v1/sessions", {})
    check(status == 201, f"POST /v1/sessions -> {status}")
    created = json.loads(body)
    path, token = "/v1/sessions/" + created["id"], created["token"]
    status, _, _ = request(port, "PATCH", path + "/settings", {"animate": True}, token)
    check(status == 200, f"PATCH settings animate -> {status}")
    return path, token


def open_stream(port, target, rcvbuf=None):
    """A socket that sent GET `target`; (socket, status, bytes after the head)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.settimeout(20)
    s.connect(("127.0.0.1", port))
    s.sendall(f"GET {target} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    head = b""
    while b"\r\n\r\n" not in head:
        # A byte at a time: a reader that must not take more than its head here.
        got = s.recv(1)
        if not got:
            break
        head += got
    m = re.match(rb"HTTP/1\.1 (\d+)", head)
    return s, int(m.group(1)) if m else 0


class Watcher(threading.Thread):
    """Reads a chunked video stream and stamps every picture chunk it gets."""

    def __init__(self, sock):
        super().__init__(daemon=True)
        self.sock = sock
        self.pictures = []  # monotonic time of each key or delta chunk
        self.stop = False

    def run(self):
        raw = b""     # the HTTP body, still chunked
        body = b""    # de-chunked: Myriad's video chunks
        self.sock.settimeout(1)
        while not self.stop:
            try:
                got = self.sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return
            if not got:
                return
            raw += got
            while True:  # HTTP chunks
                eol = raw.find(b"\r\n")
                if eol < 0:
                    break
                size = int(raw[:eol].split(b";")[0], 16)
                if len(raw) < eol + 2 + size + 2:
                    break
                body += raw[eol + 2:eol + 2 + size]
                raw = raw[eol + 2 + size + 2:]
            while len(body) >= 48:  # video chunks: payload size (u32), kind (u8), ...
                size, kind = struct.unpack_from("<IB", body, 0)
                if len(body) < 48 + size:
                    break
                if kind in (1, 2):
                    self.pictures.append(time.monotonic())
                body = body[48 + size:]

    def rate(self, since, until):
        return sum(1 for t in self.pictures if since <= t < until) / (until - since)


def wait_for(what, condition, seconds):
    """Polls `condition` (returns a value, falsy to go on) until true or `seconds` passed."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.25)
    check(False, f"{what}: not within {seconds} s")
    return None


def main():
    server = Server(sys.argv[1], "myriad-hostile-",
                    ("--lights", "8", "--encode-threads", str(ENCODE_THREADS), "--max-streams",
                     str(MAX_STREAMS)))
    port, pid = server.port, server.process.pid
    watcher = None
    samples = []  # (threads, rss KiB) through the test
    sampling = True

    def sample():
        while sampling:
            try:
                samples.append(proc_status(pid))
            except (OSError, AttributeError):
                return
            time.sleep(0.2)

    try:
        if port is None:
            return 1
        m = metrics(port)
        check(m.get("myriad_encode_threads") == ENCODE_THREADS,
              f"myriad_encode_threads {m.get('myriad_encode_threads')}, expected {ENCODE_THREADS}")

        # 0. The watcher and its baseline.
        wpath, wtoken = new_session(port)
        wsock, status = open_stream(
            port, f"{wpath}/stream?codec=vp9&width=160&height=96&fps={WATCH_FPS}&token={wtoken}")
        check(status == 200, f"watcher stream -> {status}")
        watcher = Watcher(wsock)
        watcher.start()
        time.sleep(2.0)  # its encoder made, its rate settled
        threading.Thread(target=sample, daemon=True).start()
        t0 = time.monotonic()
        time.sleep(3.0)
        baseline_rate = watcher.rate(t0, time.monotonic())
        base_threads, base_rss = proc_status(pid)
        base = metrics(port)
        print(f"baseline: watcher {baseline_rate:.1f} pictures/s (asked {WATCH_FPS}), "
              f"{base_threads} threads, RSS {base_rss / 1024:.1f} MiB, encoders made "
              f"{base.get('myriad_video_encoders_created_total')} freed "
              f"{base.get('myriad_video_encoders_freed_total')}", flush=True)
        check(baseline_rate >= 0.5 * WATCH_FPS,
              f"the watcher gets {baseline_rate:.1f} pictures/s before anything hostile")
        check(base.get("myriad_video_encoders") == 1,
              f"myriad_video_encoders {base.get('myriad_video_encoders')} with one stream open")

        def hostile_phase(name, reader):
            """Opens session X's big VP9 stream through a 4 KiB window; `reader(sock)` runs
            until the server ends the stream; returns seconds until its encoder was freed."""
            path, token = new_session(port)
            before = metrics(port)
            freed0 = before.get("myriad_video_encoders_freed_total", 0)
            started = time.monotonic()
            sock, status = open_stream(
                port, f"{path}/stream?codec=vp9&width=320&height=192&fps=30&bitrate=20000"
                      f"&token={token}", rcvbuf=4096)
            check(status == 200, f"{name}: stream -> {status}")
            done = threading.Event()
            t = threading.Thread(target=reader, args=(sock, done), daemon=True)
            t.start()
            freed = wait_for(f"{name}: its encoder freed",
                             lambda: metrics(port).get("myriad_video_encoders_freed_total", 0)
                             > freed0, 30)
            took = time.monotonic() - started
            done.set()
            t.join(5)
            sock.close()
            rate = watcher.rate(started, time.monotonic())
            after = metrics(port)
            threads, rss = proc_status(pid)
            print(f"{name}: the server ended the stream and freed its encoder after {took:.1f} s; "
                  f"watcher {rate:.1f} pictures/s meanwhile; streams open "
                  f"{after.get('myriad_streams')}, encoders {after.get('myriad_video_encoders')}; "
                  f"{threads} threads, RSS {rss / 1024:.1f} MiB", flush=True)
            check(took < 15, f"{name}: {took:.1f} s until the encoder was freed (15 at most)")
            check(freed is not None, f"{name}: the encoder was not freed")
            check(after.get("myriad_streams") == 1,
                  f"{name}: myriad_streams {after.get('myriad_streams')} after, expected 1")
            check(rate >= 0.7 * baseline_rate,
                  f"{name}: the watcher got {rate:.1f} pictures/s, below 70% of {baseline_rate:.1f}")
            request(port, "DELETE", path, None, token)

        # 1. A reader that stops after the head.
        def stopped(sock, done):
            done.wait(40)

        hostile_phase("stopped reader", stopped)

        # 2. One byte a second.
        def trickle(sock, done):
            sock.settimeout(1)
            while not done.is_set():
                try:
                    if not sock.recv(1):
                        return
                except socket.timeout:
                    pass
                except OSError:
                    return
                done.wait(1.0)

        hostile_phase("one byte a second", trickle)

        # 3. 100 streams opened and dropped.
        cpath, ctoken = new_session(port)
        before = metrics(port)
        started = time.monotonic()
        statuses = {}
        for i in range(100):
            # Each its own bitrate, so each its own channel and encoder.
            sock, status = open_stream(
                port, f"{cpath}/stream?codec=vp9&width=160&height=96&fps=10&bitrate={200 + i}"
                      f"&token={ctoken}")
            statuses[status] = statuses.get(status, 0) + 1
            sock.close()
        opened = time.monotonic() - started
        check(statuses == {200: 100}, f"100 opened and dropped: statuses {statuses}")

        def settled():
            m = metrics(port)
            live = m.get("myriad_video_encoders_created_total", 0) - m.get(
                "myriad_video_encoders_freed_total", 0)
            return m if live == 1 and m.get("myriad_streams") == 1 else None

        after = wait_for("100 dropped: every encoder but the watcher's freed", settled, 15)
        settled_after = time.monotonic() - started
        # The watcher's rate over at least 3 s from the first open (a shorter window counts a
        # handful of pictures).
        time.sleep(max(0.0, started + 3.0 - time.monotonic()))
        rate = watcher.rate(started, time.monotonic())
        if after:
            made = after["myriad_video_encoders_created_total"] - before.get(
                "myriad_video_encoders_created_total", 0)
            print(f"100 opened and dropped in {opened:.1f} s: statuses {statuses}, encoders made "
                  f"{made:.0f} and as many freed, {settled_after:.1f} s until all "
                  f"were; watcher {rate:.1f} pictures/s meanwhile", flush=True)
            # A stream whose client left before its first frame was encoded makes no encoder.
            check(made <= 100, f"100 dropped: {made:.0f} encoders made, at most 100 expected")
            check(after.get("myriad_encode_queue_depth") == 0,
                  f"encode queue depth {after.get('myriad_encode_queue_depth')} at rest")
            check(after.get("myriad_encode_seconds_count", 0) > base.get(
                "myriad_encode_seconds_count", 0), "myriad_encode_seconds counted no encode")
        # Half, not 70% as for the slow readers: 100 stream set-ups in a second share the two
        # cores of the CI machine with the watcher's encodes (seen: 6.3 to 9.6 of 10 a second
        # over six runs; 70% failed one run in five).
        check(rate >= 0.5 * baseline_rate,
              f"100 dropped: the watcher got {rate:.1f} pictures/s, below half of "
              f"{baseline_rate:.1f}")

        # Threads and memory.
        time.sleep(1.0)
        end_threads, end_rss = proc_status(pid)
        max_threads = max(t for t, _ in samples)
        max_rss = max(r for _, r in samples)
        print(f"threads: baseline {base_threads}, at most {max_threads}, at the end {end_threads}; "
              f"RSS: baseline {base_rss / 1024:.1f} MiB, at most {max_rss / 1024:.1f}, at the end "
              f"{end_rss / 1024:.1f}", flush=True)
        # An encoder here has one thread (2 pool threads: encode::encoderThreadsFor), so streams
        # add no thread; allow a few for the HTTP layer's probes.
        check(max_threads <= base_threads + 4,
              f"threads reached {max_threads}, baseline {base_threads}")
        check(end_threads <= base_threads + 1,
              f"threads at the end {end_threads}, baseline {base_threads}")
        check(max_rss - base_rss < 96 * 1024,
              f"RSS grew by {(max_rss - base_rss) / 1024:.1f} MiB (at most 96 expected)")
        final_rate = watcher.rate(time.monotonic() - 2.0, time.monotonic())
        check(final_rate >= 0.7 * baseline_rate,
              f"the watcher got {final_rate:.1f} pictures/s at the end")
    finally:
        sampling = False
        if watcher:
            watcher.stop = True
        server.stop()
    return server.verdict()


if __name__ == "__main__":
    sys.exit(main())
