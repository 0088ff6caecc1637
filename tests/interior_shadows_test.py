#!/usr/bin/env python3
"""Every light casts a shadow (issue 34) in an interior built here: three rooms in a row, 30 x 10 m,
4 m walls without a ceiling, pillars, doorways from the first room to the second and none into
the third, which is sealed. LIGHTS lights (default 100,000) fill the first two rooms below the
walls' tops, so no straight line from any of them reaches the third room's floor: every pixel of
that floor that `final` shows lit is a light leak. Sun and ambient are off (only local lights).

For each `shadows.local` (`none`, `maps`, `stochastic`): the leaked pixels of the sealed floor, and
the lit pixels of the open rooms' floor (the lights do reach them). Checked: `stochastic` leaks 0
pixels (a shadow ray per pixel through the scene's BVH: exact visibility), `none` and `maps` leak
(maps shadow at most 16 lights), every technique lights the open rooms, no NaN or Inf in raw
output, 0 validation messages.

    tests/interior_shadows_test.py MYRIAD_SERVER [--lights N] [--size WxH] [--images DIR]

--images writes each `final` as DIR/interior-NAME.png (the docs' side-by-side pictures).
Exit 0 pass, 1 fail.
"""
import argparse
import http.client
import json
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from server_script import Server, check, failures, request  # noqa: E402

WALL_TOP = 4.0
SEALED_FROM = 5.15  # the sealed room's floor: x beyond its wall (x = 5, 0.3 m thick)


def box(lo, hi):
    """A box's 8 corners and 12 triangles (outward), as (vertices, faces) with 0-based indices."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
         (3, 7, 6), (3, 6, 2), (0, 4, 7), (0, 7, 3), (1, 2, 6), (1, 6, 5)]
    return v, f


def interior_obj():
    """The rooms as OBJ text: a floor, outer walls, two inner walls (the first with two doorways,
    the second closed), four pillars in the first room and two in the second."""
    t = 0.3
    parts = [box((-15, -0.2, -5), (15, 0, 5))]  # floor, its top at y = 0
    parts += [box((-15 - t, 0, -5 - t), (15 + t, WALL_TOP, -5)),  # outer walls
              box((-15 - t, 0, 5), (15 + t, WALL_TOP, 5 + t)),
              box((-15 - t, 0, -5), (-15, WALL_TOP, 5)),
              box((15, 0, -5), (15 + t, WALL_TOP, 5))]
    # Wall at x = -5 between rooms one and two: doorways at z in [-3, -1.5] and [1.5, 3], 2.5 m high.
    for z0, z1 in ((-5, -3), (-1.5, 1.5), (3, 5)):
        parts.append(box((-5, 0, z0), (-5 + t, WALL_TOP, z1)))
    for z0, z1 in ((-3, -1.5), (1.5, 3)):
        parts.append(box((-5, 2.5, z0), (-5 + t, WALL_TOP, z1)))  # lintels
    parts.append(box((5, 0, -5), (5 + t, WALL_TOP, 5)))  # the sealed room's wall: no door
    for x, z in ((-12, -2.5), (-12, 2.5), (-8, -2.5), (-8, 2.5), (0, -2), (0, 2)):
        parts.append(box((x - 0.2, 0, z - 0.2), (x + 0.2, WALL_TOP - 0.5, z + 0.2)))
    lines, base = [], 1
    for vertices, faces in parts:
        lines += [f"v {x} {y} {z}" for x, y, z in vertices]
        lines += [f"f {a + base} {b + base} {c + base}" for a, b, c in faces]
        base += len(vertices)
    return "\n".join(lines) + "\n"


def put_model(port, path, token, body):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=300)
    c.request("PUT", path + "/model?filename=interior.obj", body=body.encode(),
              headers={"Authorization": "Bearer " + token,
                       "Content-Type": "application/octet-stream"})
    r = c.getresponse()
    payload = r.read()
    c.close()
    return r.status, payload


def floats(payload):
    return struct.unpack(f"<{len(payload) // 4}f", payload)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("server")
    p.add_argument("--lights", type=int, default=100000)
    p.add_argument("--size", default="160x96")
    p.add_argument("--images")
    a = p.parse_args()
    width, height = (int(v) for v in a.size.split("x"))
    server = Server(a.server, "myriad-interior-", ("--lights", "0", "--max-lights", str(max(a.lights, 1000))))
    if server.port is None:
        return server.verdict()
    port = server.port
    try:
        status, _, body = request(port, "POST", "/v1/sessions", {})
        check(status == 201, f"POST /v1/sessions answered {status}")
        session = json.loads(body)
        path, token = "/v1/sessions/" + session["id"], session["token"]
        status, payload = put_model(port, path, token, interior_obj())
        check(status == 200, f"PUT model answered {status}: {payload[:300]!r}")
        status, _, payload = request(port, "PATCH", path + "/settings", {
            "sun": {"intensity": 0}, "ambient": [0, 0, 0], "markers": False,
            "environment": {"mode": "none"}}, token)
        check(status == 200, f"PATCH settings answered {status}: {payload[:300]!r}")
        # Lights in rooms one and two only, below the walls' tops, reaching up to 2 m.
        status, _, payload = request(port, "POST", path + "/lights/generate", {
            "count": a.lights, "seed": 11, "bounds": {"min": [-14.8, 0.3, -4.8], "max": [4.95, 3.6, 4.8]},
            "radius": [0.5, 2.0], "intensity": [0.02, 0.08]}, token, timeout=300)
        check(status in (200, 201), f"POST lights/generate answered {status}: {payload[:300]!r}")
        view = f"/frame?width={width}&height={height}&eye=7,22,10&look_at=1,0,0.5&fov=65"
        status, _, where = request(port, "GET", path + view + "&format=raw&target=position", None, token)
        check(status == 200, f"the position target answered {status}")
        where = floats(where)
        sealed, open_floor = [], []
        for i in range(width * height):
            x, y, z = where[3 * i:3 * i + 3]
            if abs(y) > 1e-3 or abs(z) > 4.8:
                continue
            if x > SEALED_FROM + 0.05 and x < 14.9:
                sealed.append(i)
            elif -14.9 < x < 4.9:
                open_floor.append(i)
        check(len(sealed) > 100, f"only {len(sealed)} pixels of the sealed room's floor in view")
        report = {"lights": a.lights, "size": a.size, "sealedPixels": len(sealed),
                  "openPixels": len(open_floor)}
        for local in ("none", "maps", "stochastic"):
            status, _, payload = request(port, "PATCH", path + "/settings",
                                         {"shadows": {"local": local}}, token)
            check(status == 200, f"shadows.local {local}: PATCH answered {status}: {payload[:300]!r}")
            status, headers, raw = request(port, "GET", path + view + "&format=raw", None, token,
                                           timeout=300)
            check(status == 200, f"shadows.local {local}: the raw frame answered {status}")
            radiance = floats(raw)
            bad = sum(1 for v in radiance if v != v or v in (float("inf"), float("-inf")))
            check(bad == 0, f"shadows.local {local}: {bad} NaN or Inf values in raw final")
            lit = lambda i: radiance[3 * i] + radiance[3 * i + 1] + radiance[3 * i + 2] > 0.0
            leaked = sum(1 for i in sealed if lit(i))
            reached = sum(1 for i in open_floor if lit(i))
            report[local] = {"leakedPixels": leaked, "openLitPixels": reached,
                             "gpuMs": headers.get("Server-Timing", "")[:400]}
            print(f"shadows.local {local}: {leaked} of {len(sealed)} sealed-floor pixels lit "
                  f"(leaks), {reached} of {len(open_floor)} open-floor pixels lit", flush=True)
            check(reached > len(open_floor) // 2,
                  f"shadows.local {local}: only {reached} of {len(open_floor)} open-floor pixels lit")
            if local == "stochastic":
                check(leaked == 0, f"stochastic shadows leaked light onto {leaked} sealed-floor pixels")
            else:
                check(leaked > 0, f"shadows.local {local} leaked nothing: the scene does not test leaks")
            if a.images:
                status, _, png = request(port, "GET", path + view, None, token, timeout=300)
                if check(status == 200, f"shadows.local {local}: the PNG answered {status}"):
                    os.makedirs(a.images, exist_ok=True)
                    with open(os.path.join(a.images, f"interior-{local}.png"), "wb") as f:
                        f.write(png)
        status, _, metrics = request(port, "GET", "/metrics")
        count = [line for line in metrics.decode().splitlines()
                 if line.startswith("myriad_validation_messages_total")]
        check(count == ["myriad_validation_messages_total 0"], f"validation: {count}")
        print(json.dumps(report))
    finally:
        server.stop()
    return server.verdict()


if __name__ == "__main__":
    sys.exit(main())
