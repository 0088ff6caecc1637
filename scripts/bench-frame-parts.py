#!/usr/bin/env python3
"""Where a multi-target frame's time goes, as the Python client's render_path asks it.

Starts SERVER (--server: a binary or a wrapper script) with --lights generated lights, then asks
--frames frames of --targets as --format at --size over one connection, each from a new camera on
an orbit (the camera in the query, as render_path sends it), and prints the median and p90 of each
Server-Timing metric (GPU passes, readback, extra-targets, encode, queue), the client's time to
the answer's head, to its last byte, to the arrays (myriad.frames.decode_npz), and the body size.

    python3 scripts/bench-frame-parts.py --server build/release/server/myriad-server \
        --lights 1000 --frames 15
"""
import argparse, http.client, json, math, os, select, statistics, subprocess, sys, time, urllib.parse
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "client", "python"))

def start(path, lights, extra):
    p = subprocess.Popen([path, "--port", "0", "--host", "127.0.0.1", "--lights", str(lights), *extra],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    seen = b""
    while True:
        r, _, _ = select.select([p.stdout], [], [], 120)
        if not r: sys.exit("no start")
        c = os.read(p.stdout.fileno(), 4096)
        if not c: sys.exit("died")
        seen += c
        if b"http://" in seen and b"\n" in seen[seen.index(b"http://"):]:
            s = seen.index(b"http://")
            return p, seen[s:seen.index(b"\n", s)].decode().strip()

ap = argparse.ArgumentParser()
ap.add_argument("--server"); ap.add_argument("--lights", type=int, default=100000)
ap.add_argument("--size", default="1280x720"); ap.add_argument("--frames", type=int, default=40)
ap.add_argument("--targets", default="final,depth,instance-id"); ap.add_argument("--format", default="npz")
ap.add_argument("--extra", default="")
a = ap.parse_args()
w, h = a.size.split("x")
p, url = start(a.server, a.lights, a.extra.split())
try:
    u = urllib.parse.urlparse(url)
    c = http.client.HTTPConnection(u.hostname, u.port)
    c.request("POST", "/v1/sessions", body=b"{}", headers={"Content-Type": "application/json"})
    r = c.getresponse(); s = json.loads(r.read()); sid, tok = s["id"], s["token"]
    hd = {"Authorization": "Bearer " + tok}
    body = json.dumps({"count": a.lights, "seed": 1}).encode()
    c.request("POST", f"/v1/sessions/{sid}/lights/generate", body=body, headers={**hd, "Content-Type": "application/json"})
    r = c.getresponse(); print("generate", r.status, r.read()[:200])
    import numpy as np
    from myriad import frames as mf
    rows = []
    for i in range(a.frames + 5):
        ang = 2 * math.pi * i / 100
        eye = f"{9*math.cos(ang):.4f},{3.5:.4f},{9*math.sin(ang):.4f}"
        q = f"target={a.targets}&format={a.format}&width={w}&height={h}&eye={eye}&look_at=0,0.5,0"
        t0 = time.perf_counter()
        c.request("GET", f"/v1/sessions/{sid}/frame?{q}", headers=hd)
        r = c.getresponse(); t1 = time.perf_counter(); data = r.read(); t2 = time.perf_counter()
        if r.status != 200: print(r.status, data[:300]); break
        st = r.getheader("Server-Timing") or ""
        if a.format == "npz":
            arrs = mf.decode_npz(data, a.targets.split(","))
        t3 = time.perf_counter()
        m = {}
        for part in st.split(","):
            part = part.strip()
            if ";dur=" in part:
                n, d = part.split(";dur="); m[n.strip()] = m.get(n.strip(), 0) + float(d)
        m["client_head"] = (t1 - t0) * 1e3; m["client_body"] = (t2 - t1) * 1e3; m["client_decode"] = (t3 - t2) * 1e3
        m["total"] = (t3 - t0) * 1e3; m["bytes"] = len(data) / 1e6
        if i >= 5: rows.append(m)
    keys = sorted({k for r in rows for k in r})
    print(f"{a.size} {a.targets} {a.format} lights={a.lights} frames={len(rows)}")
    for k in keys:
        v = [r.get(k, 0) for r in rows]
        print(f"  {k:18s} median {statistics.median(v):8.3f}  p90 {sorted(v)[int(0.9*len(v))]:8.3f}")
finally:
    p.terminate(); p.wait()
