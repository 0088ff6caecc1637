#!/usr/bin/env python3
"""The HAProxy section of docs/deploy.md, run as written: its ```sh block taken from the document
and run by bash, line by line, in a temporary directory (with `deploy` there a link to the
repository's, so that its relative paths hold and nothing is written into the tree).

What is substituted, each required to be in the block so that a changed document fails here
rather than being skipped: `myriad-server` is the built binary, /tmp/myriad/state a temporary
directory, the ports 18080, 18081 and 18443 free ones (CTest runs tests in parallel), and
`sudo apt-get install -y haproxy` a check that haproxy is installed (scripts/install-deps.sh
--with-test-tools installs it; this test checks it is in that list). The test waits, as a person
would, for the nodes to listen before HAProxy starts and for the front to answer before the
curls. Then the outputs the document promises: `haproxy -c` "Configuration file is valid",
`{"status":"ok"} 2` (HTTP/2 through the front) and a new session from node 0 or 1.

Also the Debian service layout the section describes: a directory with 00-user.cfg (global,
user/group haproxy), 10-myriad.cfg and 20-nodes.cfg, checked by `haproxy -c -f DIR` as the unit's
`-f $CONFIG` reads it.

Usage: haproxy_doc_test.py MYRIAD_SERVER REPO_ROOT. Exit 0 pass, 1 fail, 77 skip (no haproxy,
openssl or curl).
"""
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import doc_commands  # noqa: E402
from server_script import check, failures  # noqa: E402

MARK = "@@@ doc line "


def free_ports(n):
    sockets, ports = [], []
    for _ in range(n):
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        sockets.append(s)
        ports.append(s.getsockname()[1])
    for s in sockets:
        s.close()
    return ports


def main():
    server, repo = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    started = time.monotonic()
    haproxy = shutil.which("haproxy") or ("/usr/sbin/haproxy"
                                          if os.access("/usr/sbin/haproxy", os.X_OK) else None)
    missing = [name for name, path in (("haproxy", haproxy), ("openssl", shutil.which("openssl")),
                                       ("curl", shutil.which("curl"))) if path is None]
    if missing:
        print(f"SKIP: {', '.join(missing)} not installed (scripts/install-deps.sh --with-test-tools)")
        return 77
    with open(os.path.join(repo, "scripts", "install-deps.sh")) as f:
        check(re.search(r"^\s+haproxy\s", f.read(), re.M),
              "scripts/install-deps.sh --with-test-tools does not install haproxy")

    block = doc_commands.block_with(doc_commands.read(repo), "deploy/haproxy/nodes.sh")
    p0, p1, pf = free_ports(3)
    work = tempfile.mkdtemp(prefix="myriad-haproxy-doc-")
    os.symlink(os.path.join(repo, "deploy"), os.path.join(work, "deploy"))
    substitutions = [
        ("sudo apt-get install -y haproxy", "command -v haproxy"),
        ("myriad-server ", '"$MYRIAD_SERVER" '),
        ("/tmp/myriad/state", "$WORK/state"),
        ("18080", str(p0)), ("18081", str(p1)), ("18443", str(pf)),
    ]
    text = "\n".join(c for c, _ in block)
    for old, _ in substitutions:
        check(old in text, f"the HAProxy block of docs/deploy.md no longer has {old!r}")

    wait_nodes = (f"for p in {p0} {p1}; do for i in $(seq 100); do "
                  f"curl -sf -o /dev/null http://127.0.0.1:$p/v1/health && break; sleep 0.1; done; done")
    wait_front = (f"for i in $(seq 100); do curl -sf -o /dev/null --cacert tls/tls.crt "
                  f"https://localhost:{pf}/v1/ready && break; sleep 0.1; done")
    script = ["set -u", "trap 'kill $(jobs -p) 2>/dev/null; wait' EXIT"]
    expected = []  # (line number, command as in the document, comment)
    for n, (command, comment) in enumerate(block):
        run = command
        for old, new in substitutions:
            run = run.replace(old, new)
        if command.startswith("haproxy -c"):
            script.append(wait_nodes)
        if command.startswith("curl") and not any(c.startswith("curl") for c, _ in block[:n]):
            script.append(wait_front)
        script.append(f"echo '{MARK}{n}'")
        if run.endswith("&"):  # a server in the background: its log to a file of its own
            run = run[:-1].rstrip() + f" > $WORK/background-{n}.log 2>&1 &"
            script.append(run)
        else:
            script.append(run)
            # (a response without a final newline must not swallow the marker)
            script.append(f"rc=$?; echo; echo \"{MARK}{n} exit $rc\"")
        expected.append((n, command, comment))
    script.append(f"echo '{MARK}end'")
    with open(os.path.join(work, "doc.sh"), "w") as f:
        f.write("\n".join(script) + "\n")

    env = dict(os.environ, MYRIAD_SERVER=server, WORK=work,
               PATH=os.path.dirname(haproxy) + os.pathsep + os.environ.get("PATH", ""))
    try:
        r = subprocess.run(["bash", "doc.sh"], cwd=work, env=env, capture_output=True, text=True,
                           timeout=120)
        output = r.stdout + r.stderr
        sections, exits = {}, {}
        current = None
        for line in r.stdout.splitlines():
            m = re.match(re.escape(MARK) + r"(\d+|end)( exit (\d+))?$", line)
            if m and m.group(2):
                exits[int(m.group(1))] = int(m.group(3))
            elif m:
                current = m.group(1)
                sections[current] = []
            elif current is not None:
                sections[current].append(line)
        check("end" in sections, f"the block did not run to its end: {output[-2000:]}")
        for n, command, comment in expected:
            out = "\n".join(sections.get(str(n), []))
            status = exits.get(n)
            print(f"$ {command}\n  -> exit {status if status is not None else '(background)'}"
                  f"{': ' + out.strip()[:300] if out.strip() else ''}", flush=True)
            if status is not None:
                check(status == 0, f"`{command}` exited {status}")
            if command.startswith("haproxy -c"):
                check(comment.strip('"') in out, f"`{command}`: no {comment}: {out}")
            elif command.startswith("curl") and "/v1/health" in command:
                check(out.strip() == comment, f"`{command}`: {out!r}, the document says {comment!r}")
            elif command.startswith("curl") and "POST" in command:
                try:
                    body = json.loads(out)
                    check(re.match(r"s-0[01]", body.get("id", "")),
                          f"`{command}`: a session id from node 0 or 1 expected, got {body}")
                except ValueError:
                    check(False, f"`{command}`: not JSON: {out!r}")
        for name in sorted(os.listdir(work)):
            if name.startswith("background-") and failures:
                with open(os.path.join(work, name)) as f:
                    print(f"--- {name} (end) ---\n{f.read()[-2000:]}")

        # The Debian service's layout: one directory whose .cfg files HAProxy reads in name order.
        conf = os.path.join(work, "etc-haproxy-myriad")
        os.mkdir(conf)
        with open(os.path.join(conf, "00-user.cfg"), "w") as f:
            f.write("global\n  user haproxy\n  group haproxy\n")
        shutil.copy(os.path.join(repo, "deploy", "haproxy", "myriad.cfg"),
                    os.path.join(conf, "10-myriad.cfg"))
        if check(os.path.exists(os.path.join(work, "myriad-nodes.cfg")), "no myriad-nodes.cfg"):
            shutil.copy(os.path.join(work, "myriad-nodes.cfg"), os.path.join(conf, "20-nodes.cfg"))
        c = subprocess.run([haproxy, "-c", "-f", conf], capture_output=True, text=True, timeout=30,
                           env=dict(os.environ, MYRIAD_FRONT_BIND=f"127.0.0.1:{pf}",
                                    MYRIAD_FRONT_CERT=os.path.join(work, "tls", "tls.pem")))
        print(f"$ haproxy -c -f {conf}  (the service's CONFIG directory)\n  -> exit {c.returncode}: "
              f"{(c.stdout + c.stderr).strip()[:300]}", flush=True)
        check(c.returncode == 0 and "Configuration file is valid" in c.stdout + c.stderr,
              "the CONFIG directory of 00-user.cfg, 10-myriad.cfg and 20-nodes.cfg is refused")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"total {time.monotonic() - started:.1f} s")
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
