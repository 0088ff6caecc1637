#!/usr/bin/env python3
"""The Kubernetes manifests of deploy/k8s: valid YAML, consistent with the server and the front,
and accepted by `kubectl create --dry-run=client`.

kubectl needs an API server's discovery (which kinds exist, under which group) even for a
client-side dry run, and none is reachable in a test. This test serves the discovery documents of
the kinds the manifests use (v1, apps/v1, batch/v1) from a stub on loopback and runs kubectl with
--validate=false (schema validation would download the cluster's OpenAPI document). What is
checked then: kubectl parses every object and maps every kind; the checks below cover what
validation would have (the flags the pods pass exist in `myriad-server --help`, the probes'
paths are the server's, the front's upstreams are what deploy/nginx/upstreams.sh writes for the
StatefulSet's replicas, the Job is Indexed and runs --batch).

Usage: k8s_test.py MYRIAD_SERVER REPO_ROOT. Exit 0 pass, 1 fail, 77 skip (no kubectl).
"""
import glob
import http.server
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)
    return condition


def resource(name, kind, namespaced=True):
    return {"name": name, "singularName": "", "namespaced": namespaced, "kind": kind,
            "verbs": ["create", "delete", "get", "list", "patch", "update", "watch"]}


DISCOVERY = {
    "/api": {"kind": "APIVersions", "versions": ["v1"],
             "serverAddressByClientCIDRs": [{"clientCIDR": "0.0.0.0/0",
                                             "serverAddress": "127.0.0.1"}]},
    "/apis": {"kind": "APIGroupList", "apiVersion": "v1", "groups": [
        {"name": group, "versions": [{"groupVersion": f"{group}/v1", "version": "v1"}],
         "preferredVersion": {"groupVersion": f"{group}/v1", "version": "v1"}}
        for group in ("apps", "batch")]},
    "/api/v1": {"kind": "APIResourceList", "groupVersion": "v1", "resources": [
        resource("configmaps", "ConfigMap"), resource("services", "Service"),
        resource("persistentvolumeclaims", "PersistentVolumeClaim"),
        resource("secrets", "Secret"), resource("namespaces", "Namespace", False)]},
    "/apis/apps/v1": {"kind": "APIResourceList", "apiVersion": "v1", "groupVersion": "apps/v1",
                      "resources": [resource("deployments", "Deployment"),
                                    resource("statefulsets", "StatefulSet")]},
    "/apis/batch/v1": {"kind": "APIResourceList", "apiVersion": "v1", "groupVersion": "batch/v1",
                       "resources": [resource("jobs", "Job")]},
    "/version": {"major": "1", "minor": "30", "gitVersion": "v1.30.0"},
}


class Discovery(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        body = DISCOVERY.get(self.path.split("?")[0])
        if body is None:
            self.send_response(404)
            self.send_header("Content-Length", "0")
            self.end_headers()
            return
        data = json.dumps(body).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *args):
        pass


def containers(doc):
    return doc["spec"]["template"]["spec"]["containers"]


def main():
    server, repo = sys.argv[1], sys.argv[2]
    import yaml  # python3-yaml

    k8s = os.path.join(repo, "deploy", "k8s")
    manifests = sorted(glob.glob(os.path.join(k8s, "*.yaml")))
    help_text = subprocess.run([server, "--help"], capture_output=True, text=True).stdout
    flags = set(re.findall(r"^\s+(--[a-z-]+)", help_text, re.M))
    docs = {}
    for path in manifests:
        with open(path) as f:
            loaded = [d for d in yaml.safe_load_all(f) if d]
        check(loaded, f"{path} holds no object")
        for d in loaded:
            check(all(k in d for k in ("apiVersion", "kind", "metadata")),
                  f"{path}: an object without apiVersion/kind/metadata")
            docs[(os.path.basename(path), d["kind"])] = d
    print(f"{len(manifests)} manifests, {len(docs)} objects: "
          f"{sorted(f'{f}:{k}' for f, k in docs)}", flush=True)

    # The pods' flags exist; the probes ask the server's routes.
    for (name, kind), d in docs.items():
        if kind not in ("StatefulSet", "Job"):
            continue
        for c in containers(d):
            for arg in c.get("args", []):
                flag = arg.split("=")[0]
                if flag.startswith("--"):
                    check(flag in flags, f"{name}: {flag} is not a myriad-server flag")
    for variant in ("myriad-cpu.yaml", "myriad-gpu.yaml"):
        s = docs.get((variant, "StatefulSet"))
        if not check(s is not None, f"{variant} has no StatefulSet"):
            continue
        c = containers(s)[0]
        args = c["args"]
        check("--node-id=$(POD_INDEX)" in args and "--state-dir=/state" in args,
              f"{variant}: the nodes need --node-id and one --state-dir: {args}")
        check(c["readinessProbe"]["httpGet"]["path"] == "/v1/ready" and
              c["livenessProbe"]["httpGet"]["path"] == "/v1/health", f"{variant}: probes")
        check(docs[(variant, "PersistentVolumeClaim")]["spec"]["accessModes"] == ["ReadWriteMany"],
              f"{variant}: the state volume must be ReadWriteMany")
        if variant == "myriad-gpu.yaml":
            check(c["resources"]["limits"].get("nvidia.com/gpu") == 1, "GPU variant without a GPU")
            check("--device=NVIDIA" in [a.split()[0] for a in args], "GPU variant without --device")
        replicas = s["spec"]["replicas"]
        nodes = [f"{i}=myriad-{i}.myriad-nodes:8080" for i in range(replicas)]
        expected = subprocess.run([os.path.join(repo, "deploy", "nginx", "upstreams.sh")] + nodes,
                                  capture_output=True, text=True, check=True).stdout
        with open(os.path.join(k8s, "upstreams.conf")) as f:
            check(f.read() == expected,
                  f"deploy/k8s/upstreams.conf is not upstreams.sh's output for {replicas} replicas")
    job = docs.get(("batch-job.yaml", "Job"))
    if check(job is not None, "batch-job.yaml has no Job"):
        check(job["spec"].get("completionMode") == "Indexed", "the Job is not Indexed")
        check(any(a.startswith("--batch") for a in containers(job)[0]["args"]),
              "the Job does not run --batch")

    kubectl = shutil.which("kubectl")
    if kubectl is None:
        print("SKIP: kubectl is not installed (scripts/install-deps.sh --with-test-tools)")
        return 1 if failures else 77
    stub = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Discovery)
    threading.Thread(target=stub.serve_forever, daemon=True).start()
    work = tempfile.mkdtemp(prefix="myriad-k8s-")
    try:
        kubeconfig = os.path.join(work, "kubeconfig")
        with open(kubeconfig, "w") as f:
            f.write(f"""apiVersion: v1
kind: Config
clusters: [{{name: stub, cluster: {{server: "http://127.0.0.1:{stub.server_address[1]}"}}}}]
contexts: [{{name: stub, context: {{cluster: stub, user: stub, namespace: default}}}}]
users: [{{name: stub, user: {{}}}}]
current-context: stub
""")
        env = dict(os.environ, KUBECONFIG=kubeconfig, HOME=work)
        version = subprocess.run([kubectl, "version", "--client"], capture_output=True, text=True,
                                 env=env).stdout.strip().splitlines()
        print(f"kubectl: {version[0] if version else '?'}", flush=True)
        for path in manifests:
            r = subprocess.run([kubectl, "create", "--dry-run=client", "--validate=false", "-f", path,
                                "-o", "name"], capture_output=True, text=True, env=env, timeout=60)
            names = r.stdout.split()
            print(f"kubectl create --dry-run=client -f {os.path.relpath(path, repo)}: "
                  f"exit {r.returncode}, {names}", flush=True)
            check(r.returncode == 0, f"kubectl refuses {path}: {r.stderr.strip()}")
            kinds = sorted(kind for f, kind in docs if f == os.path.basename(path))
            check(len(names) == len(kinds), f"{path}: kubectl made {names}, the file has {kinds}")
        # The objects made from files, as docs/deploy.md makes them.
        r = subprocess.run([kubectl, "create", "configmap", "myriad-front", "--dry-run=client",
                            "-o", "json",
                            "--from-file=" + os.path.join(repo, "deploy", "nginx", "myriad.conf"),
                            "--from-file=" + os.path.join(k8s, "upstreams.conf"),
                            "--from-file=" + os.path.join(k8s, "listen.conf")],
                           capture_output=True, text=True, env=env, timeout=60)
        ok = check(r.returncode == 0, f"kubectl create configmap myriad-front: {r.stderr.strip()}")
        if ok:
            keys = sorted(json.loads(r.stdout)["data"])
            front = docs[("front.yaml", "Deployment")]["spec"]["template"]["spec"]["volumes"]
            wanted = sorted(i["key"] for v in front if "configMap" in v for i in v["configMap"]["items"])
            check(keys == wanted, f"the front mounts {wanted}, the ConfigMap holds {keys}")
            print(f"configmap myriad-front: {keys}", flush=True)
    finally:
        stub.shutdown()
        shutil.rmtree(work, ignore_errors=True)
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
