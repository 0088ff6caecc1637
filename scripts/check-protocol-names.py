#!/usr/bin/env python3
"""Fails when a protocol name is written as a string literal in more than one place of the C++
under server/, protocol/ and client/cli/ (tests and docs are exempt): each route template,
problem type, technique and target name is defined once and used through its constant.

The names come from the code itself:
  - route templates and problem types: the string constants of namespaces `routes` and `problems`
    in protocol/constants.h;
  - techniques: the enum of defs.schema.json's "technique", the constants of a namespace
    `techniques` in protocol/constants.h, and every std::array of names whose identifier says
    Technique;
  - targets: every std::array of names whose identifier says Target, wherever it is defined (the
    script fails when it finds none), and the constants of a namespace `targets`.
The definition is one of the places, so a name defined twice (two arrays) fails too.

Not checked, and said so in the output: "/" (the web client's route, also the path separator),
and names that are also members of a protocol body in protocol/schemas ("position",
"metallic", "roughness": a light's and a material's members, a target's name as well). A line
may carry a comment with `names-once:` and a reason when a literal there is another thing spelt
like a protocol name (a raw channel called "depth", say).

Usage: check-protocol-names.py [REPO_ROOT]
"""
import json
import os
import re
import sys

SCOPE = ["server", "protocol", "client/cli"]
EXEMPT_DIRS = ["client/cli/tests"]
EXTENSIONS = (".h", ".hpp", ".cpp", ".cc", ".inl")
MARKER = "names-once:"
NOT_CHECKED_ROUTES = {"/": "also the path separator"}


def scan(text):
    """C++ text -> (string literals as (value, line), the text without comments, char literals
    and raw strings, lines whose comments carry MARKER). Handles //, /* */, escapes, char literals, raw strings
    and encoding prefixes."""
    literals, marked = [], set()
    code = []
    i, line, n = 0, 1, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            end = text.find("\n", i)
            end = n if end < 0 else end
            if MARKER in text[i:end]:
                marked.add(line)
            i = end
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            if MARKER in text[i:end]:
                marked.add(line)
            line += text.count("\n", i, end)
            i = end
            continue
        m = re.compile(r'(?:u8|u|U|L)?R"([^()\\ ]{0,16})\(').match(text, i)
        if m and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            close = ")" + m.group(1) + '"'
            end = text.find(close, m.end())
            end = n if end < 0 else end
            literals.append((text[m.end():end], line))
            code.append('""')
            line += text.count("\n", i, end)
            i = end + len(close)
            continue
        if c == '"' or c == "'":
            j = i + 1
            value = []
            while j < n and text[j] != c:
                if text[j] == "\\" and j + 1 < n:
                    value.append(text[j:j + 2])
                    j += 2
                    continue
                if text[j] == "\n":  # unterminated; not C++ we compile
                    break
                value.append(text[j])
                j += 1
            if c == '"':
                literals.append(("".join(value), line))
                code.append(text[i:j + 1])
            else:
                code.append("' '")
            i = j + 1
            continue
        if c == "\n":
            line += 1
        code.append(c)
        i += 1
    return literals, "".join(code), marked


def cpp_files(root):
    for top in SCOPE:
        for base, dirs, files in os.walk(os.path.join(root, top)):
            rel_base = os.path.relpath(base, root)
            dirs[:] = sorted(d for d in dirs
                             if os.path.join(rel_base, d) not in EXEMPT_DIRS and d != "build")
            for f in sorted(files):
                if f.endswith(EXTENSIONS):
                    yield os.path.join(rel_base, f)


def namespace_constants(text, namespace):
    """The string_view constants of `namespace NAME { ... }` in protocol/constants.h."""
    m = re.search(r"namespace %s \{(.*?)\}  // namespace %s" % (namespace, namespace), text, re.S)
    if not m:
        raise SystemExit("names-once: no namespace %s in protocol/constants.h" % namespace)
    return re.findall(r'std::string_view (k\w+) = "([^"]*)";', m.group(1))


def name_arrays(text):
    """(identifier, [names]) of every `std::array<std::string_view, N> kName = {"a", ...}`."""
    pattern = re.compile(
        r"std::array(?:<\s*std::string_view\s*,\s*\w+\s*>)?\s+(k\w+)\s*=\s*\{([^}]*)\}", re.S)
    for m in pattern.finditer(text):
        yield m.group(1), re.findall(r'"([^"]*)"', m.group(2))


def schema_members(root):
    members = set()

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "properties" and isinstance(value, dict):
                    members.update(value.keys())
                walk(value)
        elif isinstance(node, list):
            for item in node:
                walk(item)

    schemas = os.path.join(root, "protocol", "schemas")
    for f in os.listdir(schemas):
        with open(os.path.join(schemas, f), encoding="utf-8") as fh:
            walk(json.load(fh))
    return members


def self_test():
    text = ('// "a" in a comment\nauto x = "b"; /* "c"\n */ char q = \'"\';\n'
            'auto r = R"x(raw "d")x"; auto s = "e\\"f"; // names-once: why\n'
            'std::array<std::string_view, 2> kTargetNames = {"g", // g\n "h"};\n')
    literals, code, marked = scan(text)
    assert literals == [("b", 2), ('raw "d"', 4), ('e\\"f', 4), ("g", 5), ("h", 6)], literals
    assert marked == {4}, marked
    assert '"a"' not in code and '"c"' not in code and '"b"' in code
    assert list(name_arrays(code)) == [("kTargetNames", ["g", "h"])]


def main():
    self_test()
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                           os.path.join(os.path.dirname(__file__), ".."))
    with open(os.path.join(root, "protocol", "constants.h"), encoding="utf-8") as fh:
        constants = fh.read()
    with open(os.path.join(root, "protocol", "schemas", "defs.schema.json"), encoding="utf-8") as fh:
        schema_techniques = json.load(fh)["$defs"]["technique"]["enum"]

    files = {}
    for path in cpp_files(root):
        with open(os.path.join(root, path), encoding="utf-8", errors="replace") as fh:
            files[path] = scan(fh.read())

    names = {}  # name -> what it is
    for _, value in namespace_constants(constants, "routes"):
        names[value] = "route template"
    for ident, value in namespace_constants(constants, "problems"):
        names[value] = "problem type prefix" if ident == "kTypePrefix" else "problem type"
    for value in schema_techniques:
        names[value] = "technique"
    # Where protocol/constants.h names them one by one (namespace techniques { kTiled = ... }).
    for namespace, kind in (("techniques", "technique"), ("targets", "target")):
        if re.search(r"namespace %s \{" % namespace, constants):
            for _, value in namespace_constants(constants, namespace):
                names[value] = kind
    found_targets = []
    for path, (_, code, _) in files.items():
        for ident, values in name_arrays(code):
            if "Technique" in ident:
                for v in values:
                    names[v] = "technique"
            elif "Target" in ident:
                found_targets.append("%s (%s)" % (ident, path))
                for v in values:
                    names[v] = "target"
    if not found_targets:
        print("names-once: found no std::array of target names (an identifier with Target); "
              "update scripts/check-protocol-names.py to where they are defined")
        return 1

    not_checked = {}
    for route, why in NOT_CHECKED_ROUTES.items():
        not_checked[route] = why
    for member in schema_members(root):
        if member in names and names[member] in ("target", "technique"):
            not_checked[member] = "also a member of a protocol body"
    for name in not_checked:
        names.pop(name, None)

    places = {name: [] for name in names}
    for path, (literals, _, marked) in files.items():
        for value, line in literals:
            if value in places and line not in marked:
                places[value].append("%s:%d" % (path, line))

    repeated = {name: where for name, where in places.items() if len(where) > 1}
    for name in sorted(repeated, key=lambda n: (names[n], n)):
        print('names-once: the %s "%s" is written in %d places: %s' %
              (names[name], name, len(repeated[name]), ", ".join(repeated[name])))
    kinds = {}
    for kind in names.values():
        kinds[kind] = kinds.get(kind, 0) + 1
    print("names-once: %d files; %s; target names from %s" %
          (len(files), ", ".join("%d %s" % (k, kind if k == 1 else kind + "s") for kind, k in sorted(kinds.items())),
           ", ".join(found_targets)))
    print("names-once: not checked: " +
          ", ".join('"%s" (%s)' % (n, why) for n, why in sorted(not_checked.items())))
    if repeated:
        print("names-once: FAILED: %d names written more than once; use the constant "
              "(protocol/constants.h, or the one list of techniques and targets), or mark a line "
              "that means another thing with a comment `names-once: <why>`" % len(repeated))
        return 1
    print("names-once: every name is written once")
    return 0


if __name__ == "__main__":
    sys.exit(main())
