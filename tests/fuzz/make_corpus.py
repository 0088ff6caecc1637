#!/usr/bin/env python3
"""Writes the seed corpus of every harness of tests/fuzz from the project's own test data, so
that no corpus binaries live in the repository. One directory per harness under OUT:

  fuzz_json_body      protocol/examples/*.json and the bodies of tests/protocol/cases.json, each
                      behind the byte that picks its schema (the order of kBodies in json_body.cpp)
  fuzz_frame_query    query strings: those of the tests plus one per parameter and route
  fuzz_scene_wire     encodeScene's bytes for the built-in scene and small assimp-testmodels
                      (written by the fuzz build's fuzz_wire_seeds: the real encoder)
  fuzz_cli_multipart  frame streams as the server sends them
  fuzz_upload_files   zip archives and file sets of real models with the files they refer to
  fuzz_hdr            Radiance .hdr files: flat and run-length encoded scanlines, XYZE, tiny, cut short
  fuzz_texture        the PNG, JPEG, TGA, BMP and GIF textures of /usr/share/assimp/models
                      under 200 KB, a few cut short or with a huge header size, tiny GIF and TGA, a PSD (refused)
  fuzz_model          small models of /usr/share/assimp/models per format, zips of multi-file
                      models, and with --large also bigger ones and DamagedHelmet (geometry)

Usage: make_corpus.py FUZZ_BUILD_DIR OUT [--large]
"""
import io
import json
import math
import pathlib
import re
import struct
import subprocess
import sys
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[2]
MODELS = pathlib.Path("/usr/share/assimp/models")
HELMET = ROOT.parent / "shared" / "assets" / "DamagedHelmet"

# json_body.cpp's kBodies, in order.
SCHEMAS = ["session-create", "session-created", "session-state", "model-source", "camera",
           "camera-patch", "settings", "settings-patch", "material", "material-patch",
           "materials-list", "light", "light-new", "light-patch", "lights-add", "lights-added",
           "lights-generate", "lights-generated", "lights-page", "stats", "info", "models-list",
           "problem", "health", "camera-select"]
# model.cpp's kExtensions, in order, and where their seeds are.
EXTENSIONS = ["obj", "gltf", "glb", "ply", "stl", "off", "dae", "fbx", "3ds", "x", "ac", "ase",
              "ms3d", "md2", "nff", "smd", "zip"]


def write(directory, name, data):
    directory.mkdir(parents=True, exist_ok=True)
    (directory / name).write_bytes(data)


def json_bodies(out):
    d = out / "fuzz_json_body"
    count = 0
    for example in sorted((ROOT / "protocol" / "examples").glob("*.json")):
        if example.stem in SCHEMAS:
            write(d, "example-" + example.name, bytes([SCHEMAS.index(example.stem)]) + example.read_bytes())
            count += 1
    # Newer schemas carry their example inline ("examples").
    for schema in sorted((ROOT / "protocol" / "schemas").glob("*.schema.json")):
        name = schema.name[:-len(".schema.json")]
        for i, body in enumerate(json.loads(schema.read_text()).get("examples", [])):
            if name in SCHEMAS:
                data = json.dumps(body, separators=(",", ":")).encode()
                write(d, "example-%s-%d.json" % (name, i), bytes([SCHEMAS.index(name)]) + data)
                count += 1
    cases = json.loads((ROOT / "tests" / "protocol" / "cases.json").read_text())
    for i, case in enumerate(cases):
        if case["schema"] in SCHEMAS:
            body = json.dumps(case["body"], separators=(",", ":")).encode()
            write(d, "case-%04d" % i, bytes([SCHEMAS.index(case["schema"])]) + body)
            count += 1
    return count


def frame_queries(out):
    d = out / "fuzz_frame_query"
    queries = set()
    # Query strings in the tests' URLs ("...?width=64&height=48").
    for source in list((ROOT / "tests").glob("*.cpp")) + list((ROOT / "client" / "cli" / "tests").glob("*.cpp")):
        for match in re.finditer(r'\?([a-z_]+=[^" ]*)"', source.read_text(errors="replace")):
            queries.add(match.group(1))
    queries.update([
        "", "target=normal&format=raw&width=40&height=30", "format=jpeg&quality=40",
        "eye=1,2,3&look_at=0,0,0&fov=45", "markers=false&exposure=1.5&technique=tiled",
        "target=light-count&width=1&height=1", "time=2.5&format=png", "fps=60&format=png",
        "token=0123456789abcdef&target=depth", "eye=1e6,0,0&look_at=-1e6,0,0",
        "width=4096&height=4096", "quality=100&format=jpeg", "technique=volumes&target=clusters",
        "exposure=0.001", "fov=179.9", "target=final&target=final", "width=%31%36",
    ])
    count = 0
    for query in sorted(queries):
        for route in range(4):  # frame_query.cpp: selector % 4 picks the route
            write(d, "q%d-%04d" % (route, count), bytes([route]) + query.encode())
        count += 1
    return count * 4


def http_requests(out):
    d = out / "fuzz_http_request"
    boundary = b"XyZ"
    part = (b"--XyZ\r\nContent-Disposition: form-data; name=\"f\"; filename=\"a.obj\"\r\n"
            b"Content-Type: application/octet-stream\r\n\r\nv 0 0 0\r\n--XyZ--\r\n")
    requests = [
        b"GET /g HTTP/1.1\r\nHost: x\r\n\r\n",
        b"\r\nGET /g?a=1&b=2 HTTP/1.0\r\nConnection: keep-alive\r\n\r\n",
        b"POST /u HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n{}",
        b"POST /u HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n2;x=y\r\n{}\r\n0\r\nT: 1\r\n\r\n",
        b"POST /u HTTP/1.1\r\nContent-Type: multipart/form-data; boundary=" + boundary +
        b"\r\nContent-Length: " + str(len(part)).encode() + b"\r\n\r\n" + part,
        b"POST /u HTTP/1.1\r\nContent-Type: multipart/form-data; boundary=XyZ\r\n"
        b"Transfer-Encoding: chunked\r\n\r\n" + b"%x" % len(part) + b"\r\n" + part + b"\r\n0\r\n\r\n",
        b"GET /g HTTP/1.1\r\nContent-Length: 5\r\n\r\nGET /u HTTP/1.1\r\n\r\n",
        b"POST /u HTTP/1.1\r\nContent-Length: 4\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n",
        b"GET /g HTTP/1.1\r\nX: a\r\n folded\r\n\r\n",
        b"GET " + b"/a" * 200 + b" HTTP/1.1\r\n\r\n",
        b"GET /g HTTP/1.1\r\n" + b"X-A: 1\r\n" * 12 + b"\r\n",
        b"OPTIONS * HTTP/1.1\r\nRange: bytes=0-1\r\nExpect: 100-continue\r\n\r\n",
    ]
    count = 0
    for request in requests:
        for piece in (0, 1, 7):
            write(d, "r%02d-%d" % (count, piece), bytes([piece]) + request)
        count += 1
    return count * 3


def wire_scenes(build, out):
    # invalid/ holds files that do not load (one asks Assimp for gigabytes): no scene to encode.
    models = [p for p in sorted(MODELS.glob("*/*")) if p.suffix.lower() in
              (".obj", ".glb", ".ply", ".stl", ".off") and p.stat().st_size <= 32 * 1024
              and p.parent.name != "invalid"]
    tool = build / "tests" / "fuzz" / "fuzz_wire_seeds"
    subprocess.run([str(tool), str(out / "fuzz_scene_wire")] + [str(m) for m in models],
                   check=True, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    return len(list((out / "fuzz_scene_wire").iterdir()))


def multipart_streams(out):
    d = out / "fuzz_cli_multipart"
    header = b"multipart/x-mixed-replace; boundary=myriad-frame\n"

    def part(body, seq, length=True):
        text = b"--myriad-frame\r\nContent-Type: image/jpeg\r\n"
        if length:
            text += b"Content-Length: %d\r\n" % len(body)
        return text + b"X-Myriad-Frame: %d\r\n\r\n" % seq + body + b"\r\n"

    jpeg = b"\xff\xd8\xff\xe0\x00\x10JFIF\x00\r\n--myriad-frame\r\n\x00\xff\xd9"
    streams = {
        "one": part(b"first", 1),
        "three": part(b"first", 1) + part(jpeg, 2) + part(b"third", 3),
        "no-length": part(b"abc", 1, False) + part(b"def", 2, False),
        "closed": part(b"last", 1) + b"--myriad-frame--\r\n",
        "preamble": b"preamble text\r\n" + part(b"x", 1),
        "lf-only": b"--myriad-frame\nContent-Length: 2\n\nok\n--myriad-frame--",
    }
    for name, body in streams.items():
        write(d, name, header + body)
    write(d, "quoted", b'multipart/x-mixed-replace;boundary="a b"; x=1\n--a b\r\n\r\nbody\r\n--a b--')
    return len(streams) + 1


def zip_of(files):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def file_set(files):
    data = struct.pack("<I", len(files))
    for name, content in files.items():
        path = name.encode()
        data += struct.pack("<I", len(path)) + path + struct.pack("<Q", len(content)) + content
    return data


def multi_file_models(large):
    """Models with the files they refer to, as {member path: bytes}."""
    box = MODELS / "glTF2" / "BoxTextured-glTF"
    sets = {
        "box-textured": {p.name: p.read_bytes() for p in box.iterdir()},
        "cube-usemtl": {"cube_usemtl.obj": (MODELS / "OBJ" / "cube_usemtl.obj").read_bytes(),
                        "cube_usemtl.mtl": (MODELS / "OBJ" / "cube_usemtl.mtl").read_bytes()},
        "nested": {"models/box.obj": (MODELS / "OBJ" / "box.obj").read_bytes(),
                   "models/readme.txt": b"two members, one model"},
    }
    if large:
        sets["spider"] = {n: (MODELS / "OBJ" / n).read_bytes()
                          for n in ("spider.obj", "spider.mtl", "SpiderTex.jpg")}
        if HELMET.is_dir():  # geometry only: the textures are 3 MiB of JPEG Assimp does not decode
            sets["helmet"] = {n: (HELMET / n).read_bytes()
                              for n in ("DamagedHelmet.gltf", "DamagedHelmet.bin")}
    return sets


def upload_files(out, large):
    d = out / "fuzz_upload_files"
    count = 0
    for name, files in multi_file_models(large).items():
        if sum(len(v) for v in files.values()) > 256 * 1024:
            continue
        # upload_files.cpp: bit 0 picks the reader (0 zip, 1 file set), bit 1 asks for an entry.
        write(d, name + ".zip", bytes([0]) + zip_of(files))
        write(d, name + "-entry.zip", bytes([2]) + zip_of(files))
        write(d, name + ".set", bytes([1]) + file_set(files))
        count += 3
    return count


def models(out, large):
    d = out / "fuzz_model"
    # Larger test models take tens of seconds each under ASan (a 900 KB SMD: 30 s), past -timeout.
    limit = (256 * 1024) if large else 48 * 1024
    count = 0
    for path in sorted(MODELS.rglob("*")):
        extension = path.suffix.lower().lstrip(".")
        if not path.is_file() or extension not in EXTENSIONS or path.stat().st_size > limit:
            continue
        if extension == "gltf" and b'"uri"' in path.read_bytes() and b"data:" not in path.read_bytes():
            continue  # refers to a separate .bin: an upload of it alone is refused before Assimp
        name = str(path.relative_to(MODELS)).replace("/", "_")
        write(d, name, bytes([EXTENSIONS.index(extension)]) + path.read_bytes())
        count += 1
    for name, files in multi_file_models(large).items():
        write(d, name + ".zip", bytes([EXTENSIONS.index("zip")]) + zip_of(files))
        count += 1
    if large and HELMET.is_dir():
        write(d, "DamagedHelmet.glb", bytes([EXTENSIONS.index("glb")]) +
              (HELMET / "DamagedHelmet.glb").read_bytes())
        count += 1
    return count


def rgbe(r, g, b):
    top = max(r, g, b)
    if top < 1e-32:
        return bytes(4)
    mantissa, exponent = math.frexp(top)
    scale = mantissa * 256.0 / top
    return bytes((int(r * scale), int(g * scale), int(b * scale), exponent + 128))


def hdr_files(out):
    """Radiance files: flat scanlines, run-length encoded ones (the new form: 2 2 w, per channel
    runs), XYZE, a tiny image, and one cut short."""
    d = out / "fuzz_hdr"
    count = 0

    def header(w, h, fmt="32-bit_rle_rgbe"):
        return ("#?RADIANCE\nFORMAT=%s\n\n-Y %d +X %d\n" % (fmt, h, w)).encode("ascii")

    def flat(w, h):
        return b"".join(rgbe(1.0 + x / w, 0.5, 0.2 if y < h // 2 else 0.9)
                        for y in range(h) for x in range(w))

    def rle(w, h):
        out = bytearray()
        for y in range(h):
            out += bytes((2, 2, w >> 8, w & 255))
            pixels = [rgbe(1.0 + x / w, 0.5, 0.2 if y < h // 2 else 0.9) for x in range(w)]
            for channel in range(4):
                values = [p[channel] for p in pixels]
                i = 0
                while i < w:  # a run of the first value, then literals, alternately
                    run = 1
                    while i + run < w and run < 127 and values[i + run] == values[i]:
                        run += 1
                    if run > 2:
                        out += bytes((128 + run, values[i]))
                        i += run
                    else:
                        n = min(128, w - i)
                        out += bytes((n,)) + bytes(values[i:i + n])
                        i += n
        return bytes(out)

    seeds = {
        "flat-16x8.hdr": header(16, 8) + flat(16, 8),
        "flat-3x2.hdr": header(3, 2) + flat(3, 2),
        "rle-64x32.hdr": header(64, 32) + rle(64, 32),
        "xyze.hdr": header(16, 8, "32-bit_rle_xyze") + flat(16, 8),
        "truncated.hdr": (header(16, 8) + flat(16, 8))[:-50],
        "rgbe-magic.hdr": b"#?RGBE\n" + header(8, 4)[len(b"#?RADIANCE\n"):] + flat(8, 4),
    }
    for name, data in seeds.items():
        write(d, name, data)
        count += 1
    return count


def textures(out):
    d = out / "fuzz_texture"
    count = 0
    for pattern in ("*.png", "*.jpg", "*.jpeg", "*.JPG", "*.tga", "*.bmp", "*.gif", "*.psd"):
        for path in sorted(MODELS.rglob(pattern)):
            data = path.read_bytes()
            if len(data) > 200 * 1024:
                continue
            write(d, "%04d-%s" % (count, path.name), data)
            count += 1
            if len(data) > 64:
                write(d, "%04d-cut-%s" % (count, path.name), data[: len(data) // 2])
                count += 1
    # A PNG whose header claims 30,000 x 30,000 pixels (the rest is never reached).
    ihdr = b"IHDR" + struct.pack(">IIBBBBB", 30000, 30000, 8, 6, 0, 0, 0)
    import zlib
    png = (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + ihdr +
           struct.pack(">I", zlib.crc32(ihdr) & 0xFFFFFFFF))
    write(d, "huge-header.png", png)
    # The formats stb_image reads (image_decode_stb.cpp), tiny: a 2 x 1 GIF (two colours, LZW
    # codes clear 0 1 end), a run-length TGA, and a raw-plane RGB PSD (refused: no PSD reader).
    write(d, "two.gif", b"GIF89a\x02\x00\x01\x00\x80\x00\x00\xff\x00\x00\x00\x00\xff"
                        b"\x2c\x00\x00\x00\x00\x02\x00\x01\x00\x00\x02\x02\x44\x0a\x00\x3b")
    write(d, "two.psd", b"8BPS" + struct.pack(">H6xHIIHH", 1, 3, 1, 2, 8, 3) + bytes(12) +
                        b"\x00\x00" + bytes([10, 11, 20, 21, 30, 31]))
    write(d, "rle.tga", bytes([0, 0, 10] + [0] * 9) + struct.pack("<HHBB", 2, 1, 24, 0) +
                        b"\x81\x10\x20\x30")
    return count + 4


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    build, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    large = "--large" in sys.argv[3:]
    counts = {
        "fuzz_json_body": json_bodies(out),
        "fuzz_frame_query": frame_queries(out),
        "fuzz_http_request": http_requests(out),
        "fuzz_scene_wire": wire_scenes(build, out),
        "fuzz_cli_multipart": multipart_streams(out),
        "fuzz_upload_files": upload_files(out, large),
        "fuzz_texture": textures(out),
        "fuzz_hdr": hdr_files(out),
        "fuzz_model": models(out, large),
    }
    print("make_corpus: " + ", ".join("%s %d" % kv for kv in counts.items()))


if __name__ == "__main__":
    main()
