"""The shell commands of docs/deploy.md, as the tests that run them read them.

A command is one logical line of a ```sh block (backslash-newline continuations joined, runs of
blanks made one), its trailing comment (`  # ...`) apart; or an inline code span of the prose that
starts with a command the document tells people to run (kubectl, ctest, a script of the
repository, ...). deploy_doc_commands_test.py requires every one to be mapped to the test that runs
it; haproxy_doc_test.py and k8s_test.py take theirs from here, so that what they run is what the
document says."""
import os
import re

DOC = os.path.join("docs", "deploy.md")

# Inline code spans that are commands: those starting with one of these words.
INLINE_START = re.compile(r"(kubectl|ctest|deploy/|scripts/|myriad-server|nodes\.sh|upstreams\.sh|"
                          r"haproxy|docker|curl|sudo|cmake|systemctl|systemd-analyze|nginx|"
                          r"createuser|createdb|psql|npm|apt-get)\b")


def read(repo):
    with open(os.path.join(repo, DOC)) as f:
        return f.read()


def split_comment(line):
    """(command, comment) of one logical line; the comment starts at `#` after a blank."""
    m = re.search(r"\s#\s?(.*)$", line)
    if m is None:
        return line.strip(), ""
    return line[:m.start()].strip(), m.group(1).strip()


def sh_blocks(text):
    """Every ```sh block: a list of [(command, comment), ...], in the document's order."""
    blocks = []
    for body in re.findall(r"^```sh\n(.*?)^```", text, re.S | re.M):
        lines = []
        for line in body.replace("\\\n", " ").splitlines():
            if line.strip():
                command, comment = split_comment(re.sub(r"[ \t]+", " ", line.strip()))
                lines.append((command, comment))
        blocks.append(lines)
    return blocks


def inline_commands(text):
    prose = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    found = []
    for span in re.findall(r"`([^`\n]+)`", prose):
        if INLINE_START.match(span) and " " in span and span not in found:
            found.append(span)
    return found


def block_with(text, needle):
    """The one ```sh block holding a command that contains `needle`."""
    matches = [b for b in sh_blocks(text) if any(needle in c for c, _ in b)]
    if len(matches) != 1:
        raise LookupError(f"{DOC}: {len(matches)} sh blocks hold {needle!r}, expected 1")
    return matches[0]
