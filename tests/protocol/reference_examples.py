#!/usr/bin/env python3
"""Runs every ```sh example of protocol/reference.md against a real myriad-server, so the reference
cannot promise what the server does not do. The Conventions block creates the session; every other
block runs in bash with S, ID, TOKEN set to it and `curl` wrapped to fail on an HTTP error (--fail-with-body) and to stop streams after a
few seconds. The library and upload examples get the files they name (copies of an Assimp test
model). The block deleting the session runs last.

Usage: reference_examples.py SERVER_BINARY REFERENCE_MD
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

BOX_GLB = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb"
BOX_GLTF = "/usr/share/assimp/models/glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf"
BOX_TEXTURED_GLTF = "/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf"

# Prepended to every block: a curl that fails on HTTP errors, and ends streams (.../stream,
# .../events) after 3 s (a stream
# that was cut off by --max-time but delivered bytes is a success).
PRELUDE = r'''
set -euo pipefail
curl() {
  local args=("$@") is_stream=false
  for a in "${args[@]}"; do [[ "$a" == */stream* || "$a" == */events* ]] && is_stream=true; done
  if $is_stream; then
    local rc=0
    command curl -sS --fail-with-body --max-time 3 "${args[@]}" || rc=$?
    [[ $rc -eq 0 || $rc -eq 28 ]] || return $rc
  else
    command curl -sS --fail-with-body --max-time 120 "${args[@]}"
  fi
}
'''


def blocks(markdown):
    return re.findall(r"```sh\n(.*?)```", markdown, re.S)


def start_server(binary, models):
    server = subprocess.Popen([binary, "--port", "0", "--host", "127.0.0.1", "--models", models,
                               "--lights", "32", "--max-resolution", "1280"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        line = server.stdout.readline()
        match = re.search(r"listening on (http://\S+)", line)
        if match:
            return server, match.group(1)
        if not line and server.poll() is not None:
            break
    server.kill()
    raise SystemExit("reference-examples: the server did not start")


def write_hdr(path, width, height):
    header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width)
    pixels = bytearray()
    for y in range(height):
        for x in range(width):
            # mantissas with exponent 129 (values up to 2): a bright top half, a dark bottom
            pixels += bytes((200, 180, 120, 129)) if y < height // 2 else bytes((20, 30, 90, 128))
    with open(path, "wb") as f:
        f.write(header.encode("ascii") + bytes(pixels))


def main():
    binary, reference = sys.argv[1], sys.argv[2]
    with open(reference, encoding="utf-8") as f:
        examples = blocks(f.read())
    work = tempfile.mkdtemp(prefix="myriad-reference-")
    models = os.path.join(work, "models")
    os.makedirs(os.path.join(models, "sponza"))
    shutil.copy(BOX_GLB, os.path.join(models, "DamagedHelmet.glb"))
    shutil.copy(BOX_GLTF, os.path.join(models, "sponza", "Sponza.gltf"))
    shutil.copy(BOX_GLB, os.path.join(work, "DamagedHelmet.glb"))
    # The multi-file upload examples: a .gltf with its .bin and image in box/.
    shutil.copytree(os.path.dirname(BOX_TEXTURED_GLTF), os.path.join(work, "box"))
    # The environment examples: a small Radiance .hdr (flat RGBE scanlines), uploaded and in the
    # library.
    for path in (os.path.join(work, "sky.hdr"), os.path.join(models, "sky.hdr")):
        write_hdr(path, 32, 16)
    server, url = start_server(binary, models)
    failures = 0
    try:
        # The Conventions block creates the session every later example uses (ID, TOKEN).
        session_setup = next(b for b in examples if "eval " in b and "/v1/sessions" in b)
        delete_session = [b for b in examples if re.search(r"-X DELETE \S+/v1/sessions/\$ID -H", b)]
        ordered = [session_setup] + [b for b in examples if b not in delete_session and b != session_setup] + \
            delete_session
        env = dict(os.environ, MYRIAD_API_KEY="not-needed-without---api-key")
        for block in ordered:
            script = PRELUDE + block.replace("http://127.0.0.1:8080", url)
            if block is session_setup:
                script += '\necho "SESSION $ID $TOKEN"\n'
            started = time.monotonic()
            run = subprocess.run(["bash", "-c", script], cwd=work, env=env, capture_output=True,
                                 text=True, timeout=300)
            ok = run.returncode == 0
            if block is session_setup:
                match = re.search(r"SESSION (s-[0-9a-f]{16}) ([0-9a-f]{64})", run.stdout)
                ok = ok and match is not None
                if match:
                    env.update(S=url, ID=match.group(1), TOKEN=match.group(2))
            status = "ok" if ok else "FAILED (exit %d)" % run.returncode
            first = block.strip().splitlines()[0]
            print("%-6s %5.2f s  %s" % (status, time.monotonic() - started, first[:110]))
            if not ok:
                failures += 1
                print("  stdout: " + run.stdout[-800:].replace("\n", "\n  "))
                print("  stderr: " + run.stderr[-800:].replace("\n", "\n  "))
                if block is session_setup:
                    break
    finally:
        server.terminate()
        server.wait(timeout=60)
        shutil.rmtree(work, ignore_errors=True)
    print("reference-examples: %d blocks, %d failed" % (len(examples), failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
