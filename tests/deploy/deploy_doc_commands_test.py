#!/usr/bin/env python3
"""Every command of docs/deploy.md is run by a test.

The commands are read from the document (doc_commands.py: every line of its ```sh blocks and the
inline code spans that are commands). COMMANDS below maps each to the tests that run it, each with
a string that must be in that test's source (the evidence that it does); the test fails on a
command of the document that the table does not have (so a new command needs a test before it
lands) and on an entry the document no longer has, and checks that every test named is one CTest
knows (`ctest -N` in the build tree).

What no other test runs, this one runs, as written with the substitutions named:
- the one-machine server line (the built binary, 127.0.0.1 and a free port for 0.0.0.0:8080, the
  state directory under a temporary directory, its parents missing as on a fresh machine): health
  and readiness 200, the directory made 0700, exit 0 on SIGTERM;
- the PostgreSQL lines against a cluster of its own (initdb, superuser `postgres`: `sudo -u
  postgres` is that user over the local socket, PGHOST/PGPORT/PGUSER): createuser, createdb, then
  the server with the URL's host the cluster's socket; a session made, the tables owned by myriad;
- the Compose files through Debian's docker-compose (`config`: the Compose schema, no engine), the
  services' flags against `myriad-server --help`, the volumes and certificate paths the text names;
- deploy/nginx/self-signed-cert.sh DIR (a certificate for localhost, as the curl line needs);
- the ctest lines with -N (each selects the tests it names);
- `scripts/chaos.py ... --seconds 300` as far as its command line (the chaos CTest runs it, shorter).

Usage: deploy_doc_commands_test.py MYRIAD_SERVER REPO_ROOT BUILD_DIR. Exit 0 pass, 1 fail, 77 skip
(a tool a part needs is missing: docker-compose, PostgreSQL; the rest still runs and must pass).
"""
import json
import os
import re
import shlex
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import doc_commands  # noqa: E402
from server_script import check, failures  # noqa: E402

SELF = "deploy_doc_commands"
# CI itself (.ci/run -> scripts/test.sh) is where the build commands run.
CI = "ci"
D = "tests/deploy/"

# command (as doc_commands reads it) -> [(test, (file, evidence) or None), ...]
COMMANDS = {
    # One machine
    "scripts/install-deps.sh && cmake --preset release && cmake --build --preset release -j":
        [(CI, ("scripts/test.sh", "scripts/install-deps.sh")),
         (CI, ("scripts/test.sh", 'cmake --build --preset "$preset"')),
         (SELF, None)],
    "build/release/server/myriad-server --host 0.0.0.0 --port 8080 --state-dir /var/lib/myriad/state":
        [(SELF, None)],
    # Docker / Compose
    "docker build -t myriad -f docker/Dockerfile .":
        [("container", ("tests/container/container_test.sh", "-f docker/Dockerfile ."))],
    "docker compose -f docker/compose.yaml up --build -d":
        [(SELF, None), ("container", ("tests/container/container_test.sh", "HEALTHCHECK"))],
    "docker compose restart": [(SELF, None)],
    # nginx
    "cd build/release && ctest -R '^front$' --output-on-failure": [(SELF, None)],
    "deploy/nginx/upstreams.sh 0=HOST:PORT 1=...":
        [("front", (D + "front_test.py", '"upstreams.sh"'))],
    "deploy/nginx/self-signed-cert.sh DIR":
        [("front", (D + "front_test.py", '"self-signed-cert.sh"')), (SELF, None)],
    "scripts/install-deps.sh --with-test-tools": [(CI, ("scripts/test.sh", "--with-test-tools"))],
    # PostgreSQL
    "sudo -u postgres createuser myriad && sudo -u postgres createdb -O myriad myriad":
        [(SELF, None)],
    "myriad-server --node-id 1 --state-store 'postgresql://myriad@db.example/myriad'":
        [(SELF, None), ("store_postgres", None)],
    "python3 scripts/chaos.py --server build/release/server/myriad-server --seconds 300":
        [("chaos", ("tests/CMakeLists.txt", "scripts/chaos.py --front haproxy")), (SELF, None)],
    "cd build/release && ctest -L chaos --output-on-failure": [(SELF, None)],
    "ctest -R store_postgres": [(SELF, None)],
    # Compose, several nodes
    "deploy/nginx/self-signed-cert.sh docker/tls": [(SELF, None)],
    "docker compose -f docker/compose.cluster.yaml up --build -d": [(SELF, None)],
    "curl --cacert docker/tls/tls.crt https://localhost:8443/v1/health":
        [("front", (D + "front_test.py", "deploy/nginx/myriad.conf")), (SELF, None)],
    # HAProxy
    "sudo apt-get install -y haproxy": [("haproxy_doc", (D + "haproxy_doc_test.py", "apt-get"))],
    "myriad-server --host 127.0.0.1 --port 18080 --node-id 0 --state-dir /tmp/myriad/state "
    "--lease-ms 1000 &": [("haproxy_doc", None)],
    "myriad-server --host 127.0.0.1 --port 18081 --node-id 1 --state-dir /tmp/myriad/state "
    "--lease-ms 1000 &": [("haproxy_doc", None)],
    "deploy/haproxy/nodes.sh 0=127.0.0.1:18080 1=127.0.0.1:18081 > myriad-nodes.cfg":
        [("haproxy_doc", None)],
    "deploy/nginx/self-signed-cert.sh tls 1 && cat tls/tls.crt tls/tls.key > tls/tls.pem":
        [("haproxy_doc", None)],
    "export MYRIAD_FRONT_BIND=127.0.0.1:18443 MYRIAD_FRONT_CERT=$PWD/tls/tls.pem":
        [("haproxy_doc", None)],
    "haproxy -c -f deploy/haproxy/myriad.cfg -f myriad-nodes.cfg": [("haproxy_doc", None)],
    "haproxy -db -f deploy/haproxy/myriad.cfg -f myriad-nodes.cfg &": [("haproxy_doc", None)],
    "haproxy -c": [("haproxy_doc", (D + "haproxy_doc_test.py", '"-c", "-f", conf'))],
    "curl --cacert tls/tls.crt https://localhost:18443/v1/health -w ' %{http_version}\\n'":
        [("haproxy_doc", None)],
    "curl --cacert tls/tls.crt -X POST https://localhost:18443/v1/sessions --json '{}'":
        [("haproxy_doc", None)],
    "nodes.sh [--resolver ADDRESS:PORT]... NODE_ID=NAME:PORT ...":
        [("haproxy_dns", (D + "haproxy_cluster.py", '"--resolver"'))],
    "ctest --test-dir build/release -L haproxy --output-on-failure": [(SELF, None)],
    # Kubernetes
    "docker build -t REGISTRY/myriad:0.1.0 -f docker/Dockerfile . && "
    "docker push REGISTRY/myriad:0.1.0":
        [("container", ("tests/container/container_test.sh", "-f docker/Dockerfile .")),
         ("k8s", (D + "k8s_sources.py", "def project_version"))],
    "kubectl kustomize deploy/k8s/overlays/gpu":
        [("k8s", (D + "k8s_test.py", 'argv[1] == "kustomize"')),
         ("k8s_schema", (D + "k8s_schema_test.py", "k8s_sources.text"))],
    "kubectl kustomize": [("k8s", (D + "k8s_sources.py", '"kustomize"')), ("k8s_schema", None)],
    "kubectl apply -k deploy/k8s/overlays/cpu":
        [("k8s", (D + "k8s_test.py", '"apply"')), ("k8s_schema", None)],
    "kubectl create secret tls myriad-tls --cert=tls.crt --key=tls.key":
        [("k8s", (D + "k8s_test.py", '"secret"'))],
    "kubectl create configmap myriad-front --from-file=deploy/nginx/myriad.conf "
    "--from-file=deploy/k8s/upstreams.conf --from-file=deploy/k8s/listen.conf": [("k8s", None)],
    "kubectl apply -f deploy/k8s/front.yaml": [("k8s", None), ("k8s_schema", None)],
    "npm ci": [(CI, ("scripts/test.sh", "npm ci")),
               ("k8s_schema", (D + "k8s_schema_test.py", "node_modules"))],
    "deploy/nginx/upstreams.sh 0=myriad-0.myriad-nodes:8080 ... > deploy/k8s/upstreams.conf":
        [("k8s", (D + "k8s_test.py", '"upstreams.sh"'))],
    "kubectl rollout restart deployment/myriad-front":
        [("k8s", (D + "k8s_test.py", "kubectl.kubernetes.io/restartedAt"))],
    "nodes.sh 0=myriad-0.myriad-nodes:8080 ...":
        [("haproxy_dns", (D + "haproxy_cluster.py", '"nodes.sh"'))],
    "myriad-server --help": [("k8s", (D + "k8s_test.py", '"--help"'))],
    "kubectl create --dry-run=client --validate=false": [("k8s", None)],
    "kubectl wait": [("k8s", None)],
    # Batch
    "myriad-server --batch SPEC --index I --out DIR":
        [("batch", (D + "batch_test.py", '"--batch"'))],
    "kubectl create configmap myriad-batch-spec --from-file=spec.json=my-spec.json":
        [("k8s", (D + "k8s_test.py", "myriad-batch-spec"))],
    "kubectl apply -f deploy/k8s/batch-job.yaml": [("k8s", None), ("k8s_schema", None)],
    "kubectl wait --for=condition=complete job/myriad-batch --timeout=1h":
        [("k8s", (D + "k8s_test.py", "condition met"))],
}


def run(argv, **kw):
    kw.setdefault("capture_output", True)
    kw.setdefault("text", True)
    kw.setdefault("timeout", 60)
    return subprocess.run(argv, **kw)


def get(url, timeout=5):
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def start_server(argv, log):
    """The server from its documented argv, `--port 0` substituted by the caller; its port."""
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=log)
    m = re.search(r"listening on http://[^:]+:(\d+)", process.stdout.readline().decode())
    return process, (int(m.group(1)) if m else None)


def stop_server(process, what):
    process.send_signal(signal.SIGTERM)
    try:
        code = process.wait(30)
    except subprocess.TimeoutExpired:
        process.kill()
        code = process.wait()
    check(code == 0, f"{what}: exit {code} on SIGTERM, the document says 0")


def one_machine(server, work, command):
    """build/release/server/myriad-server --host 0.0.0.0 --port 8080 --state-dir DIR."""
    state = os.path.join(work, "var", "lib", "myriad", "state")
    argv = shlex.split(command)
    subs = {"build/release/server/myriad-server": server, "0.0.0.0": "127.0.0.1", "8080": "0",
            "/var/lib/myriad/state": state}
    for old in subs:
        check(old in argv, f"the one-machine line no longer has {old}: {command}")
    argv = [subs.get(a, a) for a in argv]
    with open(os.path.join(work, "one-machine.log"), "wb") as log:
        process, port = start_server(argv, log)
        try:
            if check(port is not None, f"`{command}` did not start"):
                health, ready = get(f"http://127.0.0.1:{port}/v1/health"), \
                    get(f"http://127.0.0.1:{port}/v1/ready")
                check(health[0] == 200 and ready[0] == 200, f"health {health}, ready {ready}")
                mode = stat.S_IMODE(os.stat(state).st_mode) if os.path.isdir(state) else None
                check(mode == 0o700, f"the state directory's mode is {mode and oct(mode)}, not 0700")
                print(f"  one machine: health {health[0]}, ready {ready[0]}, "
                      f"{os.path.relpath(state, work)} {mode and oct(mode)}", flush=True)
        finally:
            stop_server(process, "the one-machine server")


def postgres_lines(server, work, create_line, server_line):
    """The two PostgreSQL lines against a throw-away cluster; False when PostgreSQL is missing."""
    sys.path.insert(0, os.path.join(REPO, "scripts"))
    import pg_cluster
    import random
    try:
        base = pg_cluster.PostgresCluster()  # the binaries and the user to run them as
    except pg_cluster.Unavailable as e:
        print(f"SKIP part: PostgreSQL lines ({e})")
        return False
    root = tempfile.mkdtemp(prefix="myriad-pg-doc-")
    os.chmod(root, 0o755)
    base._own(root)
    data, sock = os.path.join(root, "data"), os.path.join(root, "socket")
    os.mkdir(sock)
    os.chmod(sock, 0o777)
    base._own(sock)
    postgres = None
    try:
        r = run(base.prefix + [os.path.join(base.bin, "initdb"), "-D", data, "-A", "trust",
                               "-U", "postgres", "-E", "UTF8", "--locale=C", "--no-sync"],
                cwd=root, timeout=120)
        if not check(r.returncode == 0, f"initdb: {r.stdout[-500:]} {r.stderr[-500:]}"):
            return True
        port = random.randint(20000, 60000)
        postgres = subprocess.Popen(
            base.prefix + [os.path.join(base.bin, "postgres"), "-D", data, "-k", sock,
                           "-p", str(port), "-c", "listen_addresses=", "-c", "fsync=off"],
            stdout=subprocess.DEVNULL, stderr=open(os.path.join(work, "postgres.log"), "wb"),
            cwd=root)
        env = dict(os.environ, PGHOST=sock, PGPORT=str(port), PGUSER="postgres",
                   PATH=base.bin + os.pathsep + os.environ["PATH"])
        for _ in range(300):
            if run([os.path.join(base.bin, "pg_isready"), "-q"], env=env).returncode == 0:
                break
            time.sleep(0.1)
        # `sudo -u postgres X` is X as the superuser postgres over the local socket.
        check(create_line.count("sudo -u postgres ") == 2, f"changed: {create_line}")
        r = run(["bash", "-c", create_line.replace("sudo -u postgres ", "")], env=env)
        print(f"$ {create_line}\n  -> exit {r.returncode} {r.stderr.strip()}", flush=True)
        check(r.returncode == 0, f"`{create_line}`: {r.stderr}")
        argv = shlex.split(server_line)
        url = "postgresql://myriad@db.example/myriad"
        check(argv[0] == "myriad-server" and url in argv, f"changed: {server_line}")
        local = f"postgresql://myriad@/myriad?host={sock}&port={port}"
        argv = [server] + [local if a == url else a for a in argv[1:]] + [
            "--host", "127.0.0.1", "--port", "0"]
        with open(os.path.join(work, "pg-server.log"), "wb") as log:
            process, port_http = start_server(argv, log)
            try:
                if check(port_http is not None, f"`{server_line}` did not start"):
                    req = urllib.request.Request(f"http://127.0.0.1:{port_http}/v1/sessions",
                                                 data=b"{}", method="POST",
                                                 headers={"Content-Type": "application/json"})
                    with urllib.request.urlopen(req, timeout=60) as resp:
                        session = json.loads(resp.read())
                    check(resp.status == 201 and session["id"].startswith("s-01"),
                          f"a session from node 1 expected: {resp.status} {session}")
                    owners = run([os.path.join(base.bin, "psql"), "-qAt", "-d", "myriad", "-c",
                                  "SELECT tablename || ' ' || tableowner FROM pg_tables "
                                  "WHERE tablename LIKE 'myriad_%' ORDER BY 1"], env=env).stdout
                    tables = dict(line.split() for line in owners.splitlines() if line.strip())
                    print(f"$ {server_line}\n  -> session {session['id']}, tables {tables}",
                          flush=True)
                    check(sorted(tables) == ["myriad_blobs", "myriad_leases", "myriad_sessions"]
                          and set(tables.values()) == {"myriad"},
                          f"the server's tables and their owners: {tables}")
            finally:
                stop_server(process, "the --state-store server")
    finally:
        if postgres is not None:
            postgres.terminate()
            postgres.wait(30)
        shutil.rmtree(root, ignore_errors=True)
    return True


def mount(volume):
    """(source, target) of a Compose volume, short ("SRC:DST:ro") or long syntax."""
    if isinstance(volume, str):
        return tuple(volume.split(":")[:2])
    return volume.get("source"), volume.get("target")


def compose_lines(server_help, work):
    """docker compose -f FILE up --build -d: FILE through docker-compose's `config`."""
    compose = shutil.which("docker-compose")
    if compose is None:
        print("SKIP part: docker-compose not installed (scripts/install-deps.sh --with-test-tools)")
        return False
    flags = set(re.findall(r"^\s+(--[a-z0-9-]+)", server_help, re.M))
    for name in ("compose.yaml", "compose.cluster.yaml"):
        path = os.path.join(REPO, "docker", name)
        r = run([compose, "-f", path, "config"], env=dict(os.environ, HOME=work))
        if not check(r.returncode == 0, f"docker-compose config -f docker/{name}: {r.stderr}"):
            continue
        import yaml
        config = yaml.safe_load(r.stdout)
        services = config["services"]
        print(f"  docker/{name}: valid Compose, services {sorted(services)}", flush=True)
        for sname, s in services.items():
            command = s.get("command") or []
            for arg in command:
                if arg.startswith("--"):
                    check(arg.split("=")[0] in flags,
                          f"docker/{name}: {sname} passes {arg}, not a myriad-server flag")
            if "build" in s:
                check(s["build"].get("dockerfile") == "docker/Dockerfile" and
                      os.path.samefile(s["build"]["context"], REPO),
                      f"docker/{name}: {sname} is not built from docker/Dockerfile: {s['build']}")
                # docker compose restart keeps sessions: the named volume at --state-dir.
                check("--state-dir=/state" in command and
                      any(mount(v)[:2] == ("myriad-state", "/state") for v in s.get("volumes", [])),
                      f"docker/{name}: {sname} does not keep its state in the volume myriad-state")
        if name == "compose.cluster.yaml":
            front = [s for s in services.values() if "build" not in s]
            ports = [p for s in front for p in s.get("ports", [])]
            check(any(str(p.get("published")) == "8443" for p in ports),
                  f"docker/compose.cluster.yaml publishes no 8443 (the curl line): {ports}")
            binds = [mount(v)[0] for s in front for v in s.get("volumes", [])]
            check(os.path.join(REPO, "docker", "tls") in binds,
                  f"the cluster's front does not mount docker/tls: {binds}")
    return True


def ctest_lines(build, command):
    """A ctest line of the document, listed (-N) instead of run; the tests it selects."""
    argv = shlex.split(command.split("&&")[-1])
    check(argv[0] == "ctest", f"not a ctest line: {command}")
    argv = [a for a in argv[1:] if a != "--output-on-failure"]
    if "--test-dir" in argv:
        i = argv.index("--test-dir")
        del argv[i:i + 2]
    r = run(["ctest", "--test-dir", build, "-N"] + argv)
    names = re.findall(r"Test\s+#\d+: (\S+)", r.stdout)
    check(r.returncode == 0 and names, f"`{command}` selects no test: {r.stdout} {r.stderr}")
    return names


REPO = None


def main():
    global REPO
    server, REPO, build = (os.path.abspath(a) for a in sys.argv[1:4])
    started = time.monotonic()
    text = doc_commands.read(REPO)
    blocks = doc_commands.sh_blocks(text)
    documented = [c for b in blocks for c, _ in b] + doc_commands.inline_commands(text)
    print(f"docs/deploy.md: {sum(len(b) for b in blocks)} lines in {len(blocks)} sh blocks, "
          f"{len(doc_commands.inline_commands(text))} inline commands", flush=True)

    # The table against the document, the tests against CTest's.
    for command in documented:
        check(command in COMMANDS,
              f"docs/deploy.md: no test runs `{command}`: add one, and its line to COMMANDS in "
              f"tests/deploy/deploy_doc_commands_test.py")
    for command in COMMANDS:
        check(command in documented, f"COMMANDS has `{command}`, which docs/deploy.md no longer has")
    r = run(["ctest", "--test-dir", build, "-N"])
    registered = set(re.findall(r"Test\s+#\d+: (\S+)", r.stdout))
    check(SELF in registered, f"ctest -N in {build} does not list {SELF}: {r.stdout[-500:]}")
    for command, runners in COMMANDS.items():
        for test, evidence in runners:
            if test != CI:
                check(test in registered, f"`{command}`: {test} is not a CTest")
            if evidence:
                with open(os.path.join(REPO, evidence[0])) as f:
                    check(evidence[1] in f.read(),
                          f"`{command}`: {evidence[0]} ({test}) has no {evidence[1]!r}")
    for command in documented:
        tests = dict.fromkeys(t for t, _ in COMMANDS.get(command, []))
        print(f"  {command[:90]:90} <- {', '.join(tests)}")

    skipped = False
    work = tempfile.mkdtemp(prefix="myriad-doc-commands-")
    try:
        help_text = run([server, "--help"]).stdout
        # One machine: the build line as CI runs it (scripts/test.sh), its presets; the server.
        presets = json.load(open(os.path.join(REPO, "CMakePresets.json")))
        check(any(p["name"] == "release" for p in presets["configurePresets"]) and
              any(p["name"] == "release" for p in presets["buildPresets"]),
              "CMakePresets.json has no release configure and build preset")
        check(run(["bash", "-n", os.path.join(REPO, "scripts", "install-deps.sh")]).returncode == 0,
              "scripts/install-deps.sh does not parse")
        one_machine(server, work, next(c for c in documented if c.startswith("build/release/")))

        # PostgreSQL.
        create = next(c for c in documented if "createuser" in c)
        node = next(c for c in documented if "--state-store" in c)
        skipped |= not postgres_lines(server, work, create, node)

        # chaos.py: as far as its command line.
        chaos = next(c for c in documented if "scripts/chaos.py" in c)
        argv = shlex.split(chaos)
        r = run(argv[:2] + ["--help"], cwd=REPO)
        options = [a for a in argv[2:] if a.startswith("--")]
        check(r.returncode == 0 and all(o in r.stdout for o in options),
              f"`{chaos}`: {r.returncode} {r.stderr} (options {options})")
        print(f"$ {chaos}\n  -> --help exit {r.returncode}, options {options} known", flush=True)

        # Compose.
        cert = next(c for c in documented if c.startswith("deploy/nginx/self-signed-cert.sh docker/"))
        argv = shlex.split(cert)
        tls = os.path.join(work, argv[1])
        r = run([os.path.join(REPO, argv[0]), tls] + argv[2:])
        san = run(["openssl", "x509", "-noout", "-ext", "subjectAltName", "-in",
                   os.path.join(tls, "tls.crt")]).stdout
        print(f"$ {cert}\n  -> exit {r.returncode}: {r.stdout.strip()}", flush=True)
        check(r.returncode == 0 and os.path.exists(os.path.join(tls, "tls.key")) and
              "DNS:localhost" in san, f"`{cert}`: {r.stderr} {san}")
        skipped |= not compose_lines(help_text, work)

        # The ctest lines select what they say.
        for command, wanted in (
                ("cd build/release && ctest -R '^front$' --output-on-failure", {"front"}),
                ("ctest -L deploy", {"front", "k8s", "k8s_schema", "batch", "haproxy_doc",
                                     SELF}),
                ("cd build/release && ctest -L chaos --output-on-failure", {"chaos"}),
                ("ctest -R store_postgres", {"store_postgres"}),
                ("ctest --test-dir build/release -L haproxy --output-on-failure",
                 {"haproxy_failover", "haproxy_capacity", "haproxy_dns", "haproxy_fronts",
                  "haproxy_doc"})):
            names = ctest_lines(build, command)
            print(f"$ {command}\n  -> ctest -N: {' '.join(names)}", flush=True)
            check(wanted <= set(names), f"`{command}` does not select {sorted(wanted - set(names))}")
        deselected = ctest_lines(build, "ctest -LE deploy")
        check("front" not in deselected, "ctest -LE deploy still selects front")
    finally:
        if failures:
            for name in ("one-machine.log", "pg-server.log", "postgres.log"):
                path = os.path.join(work, name)
                if os.path.exists(path):
                    print(f"--- {name} (end) ---\n{open(path, errors='replace').read()[-2000:]}")
        shutil.rmtree(work, ignore_errors=True)
    print(f"total {time.monotonic() - started:.1f} s")
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    if skipped:
        print("SKIP: a part could not run (above); the rest passed")
        return 77
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
