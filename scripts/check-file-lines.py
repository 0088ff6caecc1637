#!/usr/bin/env python3
"""CTest `render_file_lines`: no file of the renderer or the Vulkan layer is over 500 lines (issue 37).

    python3 scripts/check-file-lines.py REPO_ROOT

Every .cpp and .h under server/render and server/gpu (subdirectories included) has at most
MAX_LINES lines. STYLE.md 1: "a file past ~500 lines is asking to be split"; this holds the
renderer to it, so a file that grows past it is split along what it holds (docs/ARCHITECTURE.md
section 3, "The renderer's files") rather than left to grow. Each file over the limit is named with
its count.
"""
import os
import sys

PATHS = ("server/render", "server/gpu")
SUFFIXES = (".cpp", ".h")
MAX_LINES = 500


def line_count(path):
    with open(path, "rb") as f:
        data = f.read()
    # As `wc -l` counts them, plus a last line without its newline.
    return data.count(b"\n") + (1 if data and not data.endswith(b"\n") else 0)


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    over, checked = [], 0
    for top in PATHS:
        for base, dirs, files in os.walk(os.path.join(root, top)):
            dirs.sort()
            for name in sorted(files):
                if not name.endswith(SUFFIXES):
                    continue
                path = os.path.join(base, name)
                checked += 1
                lines = line_count(path)
                if lines > MAX_LINES:
                    over.append((os.path.relpath(path, root), lines))
    for path, lines in over:
        print(f"{path}: {lines} lines, over {MAX_LINES}")
    if over:
        print(f"render_file_lines: {len(over)} of {checked} files under {', '.join(PATHS)} are over "
              f"{MAX_LINES} lines: split each along what it holds (STYLE.md 1)")
        return 1
    if checked == 0:
        print(f"render_file_lines: no .cpp or .h file under {', '.join(PATHS)} of {root}")
        return 1
    print(f"render_file_lines: {checked} files under {', '.join(PATHS)}, none over {MAX_LINES} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
