#!/usr/bin/env python3
"""Fails when a module of server/ includes, directly or through the headers it includes, a header
its layer must not see (docs/ARCHITECTURE.md section 1):

  - service/ and encode/: no gpu/ header and no Vulkan header (the service reaches the renderer
    through render/render_queue.h; HTTP workers never touch Vulkan);
  - encode/: no render/ header either (it packs pixels, not frames);
  - scene/: no gpu/, render/ or Vulkan header;
  - gpu/: no header of another module (only gpu/ and Vulkan).

Quoted includes are followed through server/, the repository root (protocol/) and shaders/;
angle-bracket includes are checked but not followed.

Usage: check-layers.py [REPO_ROOT]
"""
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)

RULES = {
    # module: (forbidden quoted prefixes, forbidden angle-bracket prefixes)
    "service": (("gpu/",), ("vulkan/",)),
    "encode": (("gpu/", "render/"), ("vulkan/",)),
    "scene": (("gpu/", "render/"), ("vulkan/",)),
    "gpu": (("render/", "scene/", "service/", "encode/", "loader/", "protocol/"), ()),
}


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    search = [os.path.join(root, "server"), root, os.path.join(root, "shaders")]

    def resolve(name):
        for base in search:
            path = os.path.join(base, name)
            if os.path.isfile(path):
                return path
        return None

    cache = {}

    def includes(path):
        if path not in cache:
            with open(path, encoding="utf-8", errors="replace") as f:
                cache[path] = INCLUDE.findall(f.read())
        return cache[path]

    failures = []
    checked = 0
    for module, (quoted, angled) in RULES.items():
        directory = os.path.join(root, "server", module)
        for dirpath, _, files in os.walk(directory):
            for file in sorted(files):
                if not file.endswith((".h", ".cpp")):
                    continue
                start = os.path.join(dirpath, file)
                checked += 1
                # Depth-first through quoted includes, remembering how each header was reached.
                seen = {start}
                stack = [(start, [os.path.relpath(start, root)])]
                while stack:
                    path, chain = stack.pop()
                    for kind, name in includes(path):
                        banned = name.startswith(quoted) if kind == '"' else name.startswith(angled)
                        if banned:
                            failures.append(f"{module}/: {' -> '.join(chain + [name])}")
                            continue
                        if kind != '"':
                            continue
                        target = resolve(name)
                        if target and target not in seen:
                            seen.add(target)
                            stack.append((target, chain + [name]))
    for line in failures:
        print(line)
    if failures:
        print(f"{len(failures)} include(s) cross a layer (docs/ARCHITECTURE.md section 1)")
        return 1
    print(f"{checked} files of {', '.join(m + '/' for m in RULES)} checked: every layer's includes are allowed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
