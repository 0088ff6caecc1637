#!/usr/bin/env python3
"""Standard video containers opened by a player that is not Myriad's (issue 35): Debian's ffmpeg
opens GET .../stream?codec=vp9&container=webm and ?codec=h264&container=mp4 by URL.

A server with validation; a session with its lights animating (settings.animate). For each of the
two streams:
  1. ffmpeg -i URL decodes N frames of the animated session: N frames of the asked size come out
     (rawvideo rgb24, frame for frame: -fps_mode passthrough), ffmpeg names the codec and size it
     found, and the pictures change (the lights move).
  2. With every light deleted the session still animates (frames keep coming, as a player needs),
     but each frame shows the same state, so the last decoded frame must be within 35 dB PSNR of
     GET .../frame (PNG) of that state at the same size (both decoded to rgb24 by ffmpeg, PSNR in
     numpy). A still scene would not do: a live stream of a still scene sends one frame and then
     keep-alives, and ffmpeg waits for more frames to learn the stream's format.
Then container/codec pairs that do not go together are 400 with a problem naming `container`,
and the server logged no validation message (GET /v1/info). Encode times (GET .../stats
pipeline.encodeMs) are printed for the record. Bounded: each ffmpeg 20 s, the test < 60 s.

Usage: video_players_test.py MYRIAD_SERVER. Exit 0 pass, 1 fail, 77 skip (no ffmpeg/numpy).
"""
import http.client
import json
import os
import re
import shutil
import subprocess
import sys
import time

from server_script import Server, check, request

WIDTH, HEIGHT, FPS, FRAMES = 320, 180, 15, 12
STREAMS = (("webm", "codec=vp9&container=webm", "vp9", "video/webm"),
           ("mp4", "codec=h264&container=mp4", "h264", "video/mp4"))
def ffmpeg_frames(url, frames, out):
    """Decodes `frames` frames of `url` into rgb24 rawvideo at `out`: (ffmpeg's stderr, seconds)."""
    started = time.monotonic()
    r = subprocess.run(["ffmpeg", "-hide_banner", "-nostdin", "-i", url, "-frames:v", str(frames),
                        "-fps_mode", "passthrough", "-f", "rawvideo", "-pix_fmt", "rgb24", "-y",
                        out], capture_output=True, text=True, timeout=20)
    return r.returncode, r.stderr, time.monotonic() - started


def psnr(a, b, np):
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)


def main():
    try:
        import numpy as np
    except ImportError:
        print("SKIP: numpy is missing (python3-numpy)")
        return 77
    if shutil.which("ffmpeg") is None:
        print("SKIP: ffmpeg is missing (scripts/install-deps.sh --with-test-tools)")
        return 77
    server = Server(sys.argv[1], "myriad-players-")
    work, port = server.work, server.port
    try:
        if port is None:
            return 1
        base = f"http://127.0.0.1:{port}"
        size = f"width={WIDTH}&height={HEIGHT}&fps={FPS}"
        frame_bytes = WIDTH * HEIGHT * 3

        for name, query, codec, content_type in STREAMS:
            status, _, body = request(port, "POST", "/v1/sessions", {})
            check(status == 201, f"POST /v1/sessions -> {status}")
            created = json.loads(body)
            path, token = "/v1/sessions/" + created["id"], created["token"]
            status, _, _ = request(port, "PATCH", path + "/settings", {"animate": True}, token)
            check(status == 200, f"PATCH settings animate -> {status}")
            # 1 Mbit/s: a 320x180 picture at 15 fps, well above what 35 dB needs.
            url = f"{base}{path}/stream?{query}&{size}&bitrate=1000&token={token}"

            # The Content-Type and codec string a Media Source Extensions player needs.
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
            c.request("GET", f"{path}/stream?{query}&{size}&token={token}")
            r = c.getresponse()
            check(r.status == 200 and r.getheader("Content-Type") == content_type,
                  f"{name}: {r.status} {r.getheader('Content-Type')}, expected {content_type}")
            print(f"{name}: Content-Type {r.getheader('Content-Type')}, X-Myriad-Codec "
                  f"{r.getheader('X-Myriad-Codec')}", flush=True)
            c.close()

            # 1. The animated session: N frames of the asked size, pictures that change.
            out = os.path.join(work, f"{name}-animated.rgb")
            rc, err, seconds = ffmpeg_frames(url, FRAMES, out)
            got = os.path.getsize(out) if os.path.exists(out) else 0
            check(rc == 0, f"{name}: ffmpeg exited {rc}: {err[-1500:]}")
            check(got == FRAMES * frame_bytes,
                  f"{name}: ffmpeg wrote {got} bytes, {got / frame_bytes:.2f} frames; expected "
                  f"{FRAMES} frames of {WIDTH}x{HEIGHT}")
            found = re.search(r"Stream #0:0.*Video: (\w+).*?, (\d+)x(\d+)", err)
            check(found is not None and found.group(1) == codec and
                  (int(found.group(2)), int(found.group(3))) == (WIDTH, HEIGHT),
                  f"{name}: ffmpeg saw {found.group(0) if found else 'no video stream'}")
            if got == FRAMES * frame_bytes:
                frames = np.fromfile(out, np.uint8).reshape(FRAMES, HEIGHT, WIDTH, 3)
                moved = psnr(frames[0], frames[-1], np)
                check(moved < 60, f"{name}: the first and last frames are alike ({moved:.1f} dB): "
                                  "the lights did not move")
                print(f"{name}: {FRAMES} frames {WIDTH}x{HEIGHT} ({codec}) in {seconds:.1f} s; "
                      f"first vs last frame {moved:.1f} dB (animated)", flush=True)

            # 2. The same state in every frame: the decoded frame against the PNG.
            status, _, _ = request(port, "DELETE", path + "/lights", None, token)
            check(status == 204, f"DELETE lights -> {status}")
            out = os.path.join(work, f"{name}-state.rgb")
            rc, err, seconds = ffmpeg_frames(url, FRAMES, out)
            check(rc == 0, f"{name}: ffmpeg (no lights) exited {rc}: {err[-1500:]}")
            status, _, png = request(port, "GET", f"{path}/frame?width={WIDTH}&height={HEIGHT}",
                                     None, token)
            check(status == 200, f"GET frame -> {status}")
            png_path = os.path.join(work, f"{name}.png")
            with open(png_path, "wb") as f:
                f.write(png)
            reference = subprocess.run(["ffmpeg", "-hide_banner", "-nostdin", "-loglevel", "error",
                                        "-i", png_path, "-f", "rawvideo", "-pix_fmt", "rgb24",
                                        "-"], capture_output=True, timeout=20).stdout
            got = os.path.getsize(out) if os.path.exists(out) else 0
            if check(got == FRAMES * frame_bytes and len(reference) == frame_bytes,
                     f"{name}: {got} bytes of frames, {len(reference)} of the PNG"):
                frames = np.fromfile(out, np.uint8).reshape(FRAMES, HEIGHT, WIDTH, 3)
                still = np.frombuffer(reference, np.uint8).reshape(HEIGHT, WIDTH, 3)
                db = psnr(frames[-1], still, np)
                check(db >= 35, f"{name}: the last decoded frame is {db:.1f} dB from the PNG of "
                                "the same state (at least 35 expected)")
                print(f"{name}: last decoded frame vs GET .../frame PNG: {db:.1f} dB", flush=True)
            status, _, body = request(port, "GET", path + "/stats", None, token)
            pipeline = json.loads(body).get("pipeline", {}) if status == 200 else {}
            print(f"{name}: encode median {pipeline.get('encodeMs', float('nan')):.2f} ms a "
                  f"{WIDTH}x{HEIGHT} frame (this machine's CPU; the session's last "
                  f"{pipeline.get('frames')} frames)", flush=True)
            request(port, "DELETE", path, None, token)

        # Pairs that do not go together: 400 naming `container`.
        status, _, body = request(port, "POST", "/v1/sessions", {})
        created = json.loads(body)
        path, token = "/v1/sessions/" + created["id"], created["token"]
        for query in ("codec=h264&container=webm", "codec=vp9&container=mp4",
                      "codec=h264&container=myriad", "codec=vp8&container=ogg",
                      "container=webm"):
            status, headers, body = request(port, "GET", f"{path}/stream?{query}&{size}", None,
                                            token)
            problem = json.loads(body) if body.startswith(b"{") else {}
            check(status == 400 and "container" in json.dumps(problem),
                  f"{query}: {status} {body[:300]!r}, expected 400 naming container")
        status, _, body = request(port, "GET", f"{path}/stream?codec=h264&width=321&height=180",
                                  None, token)
        check(status == 400 and b"width" in body, f"h264 of width 321: {status} {body[:200]!r}")

        status, _, body = request(port, "GET", "/v1/info")
        messages = json.loads(body)["validation"]["messages"]
        check(messages == 0, f"the server logged {messages} validation messages")
    finally:
        server.stop()
    return server.verdict()


if __name__ == "__main__":
    sys.exit(main())
