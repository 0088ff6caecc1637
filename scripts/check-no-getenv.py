#!/usr/bin/env python3
"""CTest `no_getenv_in_render`: the renderer reads no environment (issue 37).

    python3 scripts/check-no-getenv.py REPO_ROOT

Every knob of server/render, server/gpu and shaders is a field of render::Tuning
(server/render/tuning.h), set through `--tune key=value`; none is read with getenv or
secure_getenv (nor std::getenv, ::getenv). Comments count too: a comment naming an environment
variable as the way to set a knob is as wrong as the call.
"""
import os
import re
import sys

PATHS = ("server/render", "server/gpu", "shaders")
CALL = re.compile(r"\b(secure_getenv|getenv)\b")


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    found, checked = [], 0
    for top in PATHS:
        for base, _, files in os.walk(os.path.join(root, top)):
            for name in sorted(files):
                path = os.path.join(base, name)
                try:
                    with open(path, encoding="utf-8") as f:
                        text = f.read()
                except (OSError, UnicodeDecodeError):
                    continue
                checked += 1
                for n, line in enumerate(text.split("\n"), 1):
                    if CALL.search(line):
                        found.append(f"{os.path.relpath(path, root)}:{n}: {line.strip()}")
    for line in found:
        print(line)
    if found:
        print(f"no_getenv_in_render: {len(found)} getenv/secure_getenv in {', '.join(PATHS)}: "
              "add a render::Tuning knob (server/render/tuning.h) and set it with --tune instead")
        return 1
    print(f"no_getenv_in_render: {checked} files of {', '.join(PATHS)} checked: no getenv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
