"""What the haproxy_* CTests (and scripts/chaos.py's HAProxy fronts) share: Myriad nodes on
loopback addresses named by a DNS stub (dns_stub.py), and HAProxy fronts running
deploy/haproxy/myriad.cfg with the file deploy/haproxy/nodes.sh writes for them, as this user, TLS
with a self-signed certificate.

A node is NAME = node<N>.myriad.test, answered by the stub with 127.0.0.<10 + N> (another address
after a move); every node listens on a port of its own, fixed for the test, so that the DNS answer
is all that changes when it moves. Failures are collected by server_script.check()."""
import http.client
import json
import os
import re
import shutil
import signal
import socket
import ssl
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import server_script  # noqa: E402
from server_script import check, failures  # noqa: E402,F401
from dns_stub import DnsStub  # noqa: E402,F401

SKIP = 77
DOMAIN = "myriad.test"
BACKENDS = ("myriad_sessions", "myriad_new", "myriad_any")


def find_haproxy():
    for candidate in (shutil.which("haproxy"), "/usr/sbin/haproxy"):
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    return None


def node_name(node_id):
    return f"node{node_id}.{DOMAIN}"


def free_port(hosts):
    """A port free on every one of `hosts` (a node keeps its port when it moves address)."""
    for _ in range(50):
        with socket.socket() as s:
            s.bind((hosts[0], 0))
            port = s.getsockname()[1]
        try:
            for host in hosts[1:]:
                with socket.socket() as s:
                    s.bind((host, port))
            return port
        except OSError:
            continue
    raise RuntimeError("no port free on " + ", ".join(hosts))


def percentile(values, p):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(len(ordered) * p))] if ordered else float("nan")


def make_certificate(repo, work):
    """A self-signed certificate for localhost in `work` (deploy/nginx/self-signed-cert.sh): the
    PEM file HAProxy's MYRIAD_FRONT_CERT names (certificate and key) and a client context trusting
    it."""
    subprocess.run([os.path.join(repo, "deploy", "nginx", "self-signed-cert.sh"), work, "1"],
                   check=True, capture_output=True)
    crt, key = os.path.join(work, "tls.crt"), os.path.join(work, "tls.key")
    cert_pem = os.path.join(work, "tls.pem")
    with open(cert_pem, "wb") as out:
        for part in (crt, key):
            with open(part, "rb") as f:
                out.write(f.read())
    return cert_pem, ssl.create_default_context(cafile=crt)


class Node:
    """One myriad-server (--node-id, the shared --state-dir) on HOST:PORT, stderr in WORK."""

    def __init__(self, server, node_id, state_dir, work, host, port, args=()):
        self.id = node_id
        self.host, self.port = host, port
        self.log = os.path.join(work, f"node{node_id}.log")
        self.process = subprocess.Popen(
            [server, "--host", host, "--port", str(port), "--node-id", str(node_id),
             "--state-dir", state_dir, "--lights", "4", "--validate", *args],
            stdout=subprocess.PIPE, stderr=open(self.log, "ab"))

    def wait_listening(self):
        line = self.process.stdout.readline().decode()
        if not re.search(r"listening on http://%s:%d" % (re.escape(self.host), self.port), line):
            raise RuntimeError(f"node {self.id} did not start on {self.host}:{self.port}: {line!r}")
        return self

    def request(self, method, path, body=None, token=None):
        """A request straight to this node: (status, headers with lower-case names, body)."""
        status, headers, payload = server_script.request(self.port, method, path, body, token,
                                                         timeout=30, host=self.host)
        return status, {k.lower(): v for k, v in headers.items()}, payload

    def kill(self, sig=signal.SIGKILL):
        self.process.send_signal(sig)
        if sig in (signal.SIGKILL, signal.SIGTERM):
            self.process.wait(30)

    def stop(self):
        """SIGTERM (after SIGCONT: a stopped node cannot exit); checks it exits 0."""
        if self.process.poll() is not None:
            return
        self.process.send_signal(signal.SIGCONT)
        self.process.terminate()
        try:
            code = self.process.wait(20)
            check(code == 0, f"node {self.id} exited {code} on SIGTERM")
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
            check(False, f"node {self.id} did not stop within 20 s")


class Front:
    """HAProxy with deploy/haproxy/myriad.cfg and nodes.sh's file for `node_ids` (names resolved by
    `dns`), listening with TLS on a free port of 127.0.0.1. request() is thread-safe (one kept-alive
    connection per thread)."""

    def __init__(self, haproxy, repo, work, name, node_ids, ports, dns, cert_pem, context):
        self.name = name
        self.dir = os.path.join(work, name)
        os.makedirs(self.dir)
        nodes_cfg = os.path.join(self.dir, "nodes.cfg")
        with open(nodes_cfg, "w") as f:
            subprocess.run([os.path.join(repo, "deploy", "haproxy", "nodes.sh"),
                            "--resolver", "%s:%d" % dns.address] +
                           [f"{i}={node_name(i)}:{ports[i]}" for i in node_ids],
                           stdout=f, check=True)
        # The test's own addition: HAProxy's runtime API on a socket, to wait for what the health
        # checks see (HAProxy merges this global section with myriad.cfg's).
        self.admin = os.path.join(self.dir, "admin.sock")
        test_cfg = os.path.join(self.dir, "test.cfg")
        with open(test_cfg, "w") as f:
            f.write(f"global\n  stats socket {self.admin} mode 600 level admin\n")
        self.port = free_port(["127.0.0.1"])
        # Every client of the test is 127.0.0.1: the per-address request rate is not what is tested.
        env = dict(os.environ, MYRIAD_FRONT_BIND=f"127.0.0.1:{self.port}",
                   MYRIAD_FRONT_CERT=cert_pem, MYRIAD_FRONT_REQUESTS_10S="1000000")
        command = [haproxy, "-db", "-f", os.path.join(repo, "deploy", "haproxy", "myriad.cfg"),
                   "-f", nodes_cfg, "-f", test_cfg]
        test = subprocess.run(command + ["-c"], env=env, capture_output=True, text=True)
        if test.returncode != 0:
            raise RuntimeError(f"haproxy -c refuses the config: {test.stdout}{test.stderr}")
        self.log = os.path.join(self.dir, "haproxy.log")
        self.process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL,
                                        stderr=open(self.log, "ab"))
        self.context = context
        self.local = threading.local()
        deadline = time.monotonic() + 20
        while True:
            try:
                if self.request("GET", "/front/health", timeout=2)[0] == 200:
                    break
            except OSError:
                pass
            if time.monotonic() > deadline or self.process.poll() is not None:
                with open(self.log, errors="replace") as f:
                    log = f.read()[-2000:]
                raise RuntimeError(f"front {name} did not answer within 20 s: {log}")
            time.sleep(0.1)

    def states(self):
        """{(backend, server): status} as HAProxy's health checks see them ("UP", "DOWN", "MAINT",
        "UP 1/2", ...), from `show stat` on the runtime API."""
        with socket.socket(socket.AF_UNIX) as s:
            s.settimeout(5)
            s.connect(self.admin)
            s.sendall(b"show stat\n")
            data = b""
            while True:
                chunk = s.recv(65536)
                if not chunk:
                    break
                data += chunk
        lines = data.decode().splitlines()
        header = lines[0].lstrip("# ").split(",")
        states = {}
        for line in lines[1:]:
            row = dict(zip(header, line.split(",")))
            if row.get("svname") not in (None, "FRONTEND", "BACKEND"):
                states[(row["pxname"], row["svname"])] = row["status"]
        return states

    def wait_states(self, wanted, deadline_s=10):
        """Waits until every (backend, server) of `wanted` has exactly that status ("UP 1/2", a
        node going down, is not "UP"); True when they did."""
        end = time.monotonic() + deadline_s
        while True:
            states = self.states()
            if all(states.get(key) == status for key, status in wanted.items()):
                return True
            if time.monotonic() > end:
                print(f"{self.name}: still {states}", flush=True)
                return False
            time.sleep(0.05)

    def wait_nodes(self, node_ids, status="UP", deadline_s=10, backends=BACKENDS):
        """Waits until the nodes have `status` in the backends (all three by default)."""
        return self.wait_states({(b, f"node{i}"): status for b in backends for i in node_ids},
                                deadline_s)

    def request(self, method, path, body=None, token=None, timeout=60, headers=None):
        """(status, headers with lower-case names, body); `headers` are sent as well (If-Match). A
        connection error raises OSError (or http.client's); the next request opens a new
        connection."""
        headers = dict(headers or {})
        if token:
            headers["Authorization"] = "Bearer " + token
        data = None
        if body is not None:
            data = json.dumps(body).encode()
            headers["Content-Type"] = "application/json"
        elif method in ("POST", "PUT", "PATCH"):
            data = b""
        while True:
            c = getattr(self.local, "c", None)
            reused = c is not None
            if c is None:
                c = self.local.c = http.client.HTTPSConnection(
                    "localhost", self.port, context=self.context, timeout=timeout)
            c.timeout = timeout
            if c.sock is not None:
                c.sock.settimeout(timeout)
            try:
                c.request(method, path, body=data, headers=headers)
                r = c.getresponse()
                payload = r.read()
                if r.getheader("Connection", "").lower() == "close":
                    c.close()
                    self.local.c = None
                return r.status, {k.lower(): v for k, v in r.getheaders()}, payload
            except (http.client.HTTPException, OSError) as e:
                c.close()
                self.local.c = None
                # A kept-alive connection the front closed while idle (timeout http-keep-alive):
                # a GET once more on a new one, as browsers do. Anything else is the test's.
                if reused and method == "GET" and isinstance(
                        e, (http.client.RemoteDisconnected, BrokenPipeError,
                            ConnectionResetError)):
                    continue
                raise OSError(f"{method} {path} through {self.name}: {e!r}") from e

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


class Cluster:
    """The work directory, the DNS stub, the certificate, nodes and fronts; close() ends them all
    and, when a check failed, prints the end of every log."""

    def __init__(self, server, repo, prefix):
        self.server, self.repo = server, repo
        self.started = time.monotonic()
        self.work = tempfile.mkdtemp(prefix=prefix)
        self.state_dir = os.path.join(self.work, "state")
        self.dns = DnsStub()
        self.cert_pem, self.context = make_certificate(repo, self.work)
        self.nodes = {}
        self.ports = {}
        self.fronts = []
        self.logs = []

    def start_node(self, node_id, host=None, args=()):
        """Starts node `node_id` on HOST (default 127.0.0.<10 + id>) at its port and points its
        name there. Returns the Node once it listens."""
        host = host or f"127.0.0.{10 + node_id}"
        self.reserve_port(node_id)
        node = Node(self.server, node_id, self.state_dir, self.work, host, self.ports[node_id],
                    args)
        self.nodes[node_id] = node
        node.wait_listening()
        self.dns.set(node_name(node_id), host)
        return node

    def reserve_port(self, node_id):
        """Node `node_id`'s port, chosen once: free on its address and on the one it may move to
        (127.0.0.<30 + id>), so that a front can name a node before it runs."""
        if node_id not in self.ports:
            self.ports[node_id] = free_port([f"127.0.0.{10 + node_id}",
                                             f"127.0.0.{30 + node_id}"])
        return self.ports[node_id]

    def start_front(self, name, node_ids):
        """A front for `node_ids`, returned once every running one is UP in its three backends."""
        front = Front(find_haproxy(), self.repo, self.work, name, node_ids, self.ports, self.dns,
                      self.cert_pem, self.context)
        self.fronts.append(front)
        running = [i for i in node_ids
                   if i in self.nodes and self.nodes[i].process.poll() is None]
        if not front.wait_nodes(running, deadline_s=20):
            raise RuntimeError(f"front {name}: nodes {running} not all UP within 20 s")
        return front

    def close(self):
        for front in self.fronts:
            front.stop()
        for node in self.nodes.values():
            node.stop()
        self.dns.close()
        if failures:
            logs = [n.log for n in self.nodes.values()] + [f.log for f in self.fronts]
            for log in logs:
                try:
                    with open(log, "rb") as f:
                        print(f"--- {os.path.relpath(log, self.work)} (end) ---")
                        print(f.read()[-2500:].decode(errors="replace"))
                except OSError:
                    pass
        shutil.rmtree(self.work, ignore_errors=True)

    def verdict(self):
        return server_script.verdict(self.started)


def wait_for(front, method, path, token, deadline_s, want=lambda st, h, b: st == 200, body=None,
             poll=0.05):
    """Asks until `want` holds (or deadline_s passes): (seconds taken, last status, headers,
    body, answers seen as {status: count})."""
    t0 = time.monotonic()
    seen = {}
    last = (None, {}, b"")
    while True:
        try:
            last = front.request(method, path, body, token, timeout=max(0.5, deadline_s))
            seen[last[0]] = seen.get(last[0], 0) + 1
            if want(*last):
                return time.monotonic() - t0, last[0], last[1], last[2], seen
        except OSError:
            seen["error"] = seen.get("error", 0) + 1
        if time.monotonic() - t0 > deadline_s:
            return None, last[0], last[1], last[2], seen
        time.sleep(poll)


def skip_without_haproxy():
    if find_haproxy() is None or shutil.which("openssl") is None:
        print("SKIP: haproxy or openssl is not installed (scripts/install-deps.sh "
              "--with-test-tools)")
        sys.exit(SKIP)
