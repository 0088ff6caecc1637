#!/usr/bin/env python3
"""CTest `performance_doc`: docs/performance.md stays one page of current, backed figures.

    python3 tests/docs/check_performance_doc.py REPO_ROOT

Fails (exit 1, one line per problem) when:
  - docs/performance.md is over 400 lines;
  - a figure line names no result file: every data row of a table must name an existing path
    under bench/results/, a date (YYYY-MM-DD) and a command key (**H1**, **L2**, ...) that the page
    defines in a command list; a prose line with a measured figure (a number with ms, fps,
    frames/s, Mbit/s, MB, KB, MiB, GiB; not a target after <= or >=) must name a result file too;
  - a table sits under no `## ` heading naming its device (H200, H100, lavapipe);
  - a cited result file is missing;
  - any result file sits under server/ (results live in bench/results/ at the repository's top);
  - a file under bench/results/transcribed/ does not say "transcribed_from_history": true.
"""
import json
import os
import re
import sys

MAX_LINES = 400
DEVICES = ("H200", "H100", "lavapipe")
RESULT = re.compile(r"bench/results/[^\s`|)(,;]+")
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")
KEY_DEF = re.compile(r"^- \*\*([A-Z]+\d+)\*\*")
KEY_VARIANT = re.compile(r"\(([A-Z]+\d+-[A-Z0-9]+):")
KEY_USE = re.compile(r"\b([A-Z]+\d+(?:-[A-Z0-9]+)?)\b")
FIGURE = re.compile(r"(?<![<>]= )(?<![\d.])\d[\d,.]*\s?(ms|fps|frames/s|Mbit/s|MB|KB|MiB|GiB)\b")


def problems(root):
    page = os.path.join(root, "docs", "performance.md")
    with open(page, encoding="utf-8") as f:
        lines = f.read().split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    out = []
    if len(lines) > MAX_LINES:
        out.append(f"docs/performance.md: {len(lines)} lines, over {MAX_LINES}: move history to bench/history/")

    keys = set()
    for line in lines:
        m = KEY_DEF.match(line)
        if m:
            keys.add(m.group(1))
            keys.update(KEY_VARIANT.findall(line))

    def cited(n, line):
        found = RESULT.findall(line)
        for path in found:
            if not os.path.exists(os.path.join(root, path.rstrip("."))):
                out.append(f"docs/performance.md:{n}: cited result {path} does not exist")
        return found

    heading = None
    in_code = False
    table_row = 0
    for n, line in enumerate(lines, 1):
        if line.startswith("```"):
            in_code = not in_code
            continue
        if in_code:
            continue
        if line.startswith("## "):
            heading = line
        if not line.startswith("|"):
            table_row = 0
            if KEY_DEF.match(line):
                cited(n, line)
                continue
            if FIGURE.search(line) and not cited(n, line):
                out.append(f"docs/performance.md:{n}: a figure with no result file: {line.strip()[:80]}")
            continue
        table_row += 1
        if table_row == 1:
            if heading is None or not any(d in heading for d in DEVICES):
                out.append(f"docs/performance.md:{n}: a table under no device's heading ({heading})")
            continue
        if re.fullmatch(r"\|[-| :]+\|", line.strip()):
            continue
        if not cited(n, line):
            out.append(f"docs/performance.md:{n}: a figure row naming no result file under bench/results/")
        if not DATE.search(line):
            out.append(f"docs/performance.md:{n}: a figure row without its date (YYYY-MM-DD)")
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not any(c in keys for c in cells):
            used = [k for c in cells for k in KEY_USE.findall(c) if k == c]
            out.append(f"docs/performance.md:{n}: a figure row without a defined command key "
                       f"(defined: {', '.join(sorted(keys)) or 'none'}; row has {used or 'none'})")

    # A results folder anywhere under server/, or a run's output (dated, or lavapipe-*) there.
    run_output = re.compile(r"(20\d\d-\d\d-\d\d|^lavapipe-).*\.(json|txt|log|tgz|csv)$")
    for base, dirs, files in os.walk(os.path.join(root, "server")):
        for name in dirs + files:
            if (name == "results" and name in dirs) or (name in files and run_output.search(name)):
                out.append(f"{os.path.relpath(os.path.join(base, name), root)}: result files under "
                           "server/: they belong in bench/results/")
    transcribed = os.path.join(root, "bench", "results", "transcribed")
    if os.path.isdir(transcribed):
        for name in sorted(os.listdir(transcribed)):
            path = os.path.join(transcribed, name)
            try:
                with open(path, encoding="utf-8") as f:
                    doc = json.load(f)
            except (OSError, ValueError) as e:
                out.append(f"bench/results/transcribed/{name}: not readable JSON ({e})")
                continue
            missing = [k for k in ("date", "device", "command", "source") if k not in doc]
            if doc.get("transcribed_from_history") is not True or missing:
                out.append(f"bench/results/transcribed/{name}: needs \"transcribed_from_history\": "
                           f"true and date, device, command, source (missing: {missing})")
    out.extend(section_citations(root))
    return out


# A code comment citing a section of a document by name (`docs/performance.md, "PNG encoding"`):
# the document must have it, as a heading (or, in ARCHITECTURE.md, a bold lead-in), so that a
# figure moved to bench/history/ is not cited where it no longer is.
CITATION = re.compile(r'((?:docs|bench/history)/[\w.-]+\.md)[,:]?\s*"([^"\n]+)"')
CITING = ("server", "client", "tests", "scripts", "shaders")
SOURCE = (".cpp", ".h", ".js", ".mjs", ".py", ".sh", ".comp", ".glsl", ".txt")


def section_citations(root):
    out, names = [], {}
    for top in CITING:
        for base, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = [d for d in dirs if d not in ("node_modules", "__pycache__")]
            for name in files:
                if not name.endswith(SOURCE):
                    continue
                path = os.path.join(base, name)
                try:
                    with open(path, encoding="utf-8") as f:
                        text = f.read()
                except (OSError, UnicodeDecodeError):
                    continue
                # Comments wrap: a citation may run over a line break and the comment marker.
                flat = re.sub(r"\n\s*(//|#|\*)?\s*", " ", text)
                for doc, section in CITATION.findall(flat):
                    if doc not in names:
                        try:
                            with open(os.path.join(root, doc), encoding="utf-8") as f:
                                body = f.read()
                        except OSError:
                            body = None
                        names[doc] = None if body is None else [
                            l.lower() for l in body.split("\n")
                            if l.startswith("#") or l.lstrip("- ").startswith("**")]
                    rel = os.path.relpath(path, root)
                    if names[doc] is None:
                        out.append(f"{rel}: cites {doc}, which does not exist")
                    elif not any(section.lower() in l for l in names[doc]):
                        out.append(f"{rel}: cites {doc} \"{section}\", which has no such section")
    return out


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "..")
    found = problems(os.path.abspath(root))
    for p in found:
        print(p)
    if found:
        print(f"performance_doc: {len(found)} problem(s)")
        return 1
    print("performance_doc: docs/performance.md is one page of dated figures, each backed by a result file")
    return 0


if __name__ == "__main__":
    sys.exit(main())
