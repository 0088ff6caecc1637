#!/usr/bin/env python3
"""The Kubernetes manifests of deploy/k8s: valid YAML, consistent with the server and the front,
and accepted by `kubectl create --dry-run=client`. The kustomizations (base, overlays/cpu,
overlays/gpu) are checked as `kubectl kustomize` renders them, which is what `kubectl apply -k`
applies (k8s_sources.py).

kubectl needs an API server's discovery (which kinds exist, under which group) even for a
client-side dry run, and none is reachable in a test. This test serves the discovery documents of
the kinds the manifests use (v1, apps/v1, batch/v1, policy/v1) from a stub on loopback and runs
kubectl with --validate=false (schema validation would download the cluster's OpenAPI document).
What is checked then: kubectl parses every object and maps every kind; the checks below cover what
validation would have (the flags the pods pass exist in `myriad-server --help`, the probes'
paths are the server's, the front's upstreams are what deploy/nginx/upstreams.sh writes for the
StatefulSet's replicas, the Job is Indexed and runs --batch), and what issue 33 asks of them:
every image pinned (a tag, not latest; Myriad's the project's version), every container with CPU
and memory requests and limits, every replicated workload under a PodDisruptionBudget that lets
one pod go and keeps one, the GPU overlay on GPU nodes (nodeSelector, the nvidia.com/gpu
toleration and limit, --device=NVIDIA) and the CPU overlay off GPUs. Then docs/deploy.md's kubectl
commands, read from the document and run as written against the stub (run_documented). The
schemas themselves are the k8s_schema test's (k8s_schema_test.py).

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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import doc_commands  # noqa: E402
import k8s_sources  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from server_script import check, failures  # noqa: E402


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
        for group in ("apps", "batch", "policy")]},
    "/api/v1": {"kind": "APIResourceList", "groupVersion": "v1", "resources": [
        resource("configmaps", "ConfigMap"), resource("services", "Service"),
        resource("persistentvolumeclaims", "PersistentVolumeClaim"),
        resource("secrets", "Secret"), resource("namespaces", "Namespace", False)]},
    "/apis/apps/v1": {"kind": "APIResourceList", "apiVersion": "v1", "groupVersion": "apps/v1",
                      "resources": [resource("deployments", "Deployment"),
                                    resource("statefulsets", "StatefulSet")]},
    "/apis/batch/v1": {"kind": "APIResourceList", "apiVersion": "v1", "groupVersion": "batch/v1",
                       "resources": [resource("jobs", "Job")]},
    "/apis/policy/v1": {"kind": "APIResourceList", "apiVersion": "v1",
                        "groupVersion": "policy/v1",
                        "resources": [resource("poddisruptionbudgets", "PodDisruptionBudget")]},
    "/version": {"major": "1", "minor": "30", "gitVersion": "v1.30.0"},
}


class Discovery(http.server.BaseHTTPRequestHandler):
    """The discovery documents above, and the few objects the documented commands read: OBJECTS
    maps a path to an object (GET), a list of it (GET of its collection, as `kubectl wait` lists
    and watches) and takes a PATCH of it (`kubectl rollout restart`), recorded in PATCHES."""
    OBJECTS = {}
    PATCHES = []

    def send(self, status, body):
        data = json.dumps(body).encode() if body is not None else b""
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def do_GET(self):
        path, _, query = self.path.partition("?")
        if path in DISCOVERY:
            return self.send(200, DISCOVERY[path])
        if path in self.OBJECTS:
            return self.send(200, self.OBJECTS[path])
        items = [o for p, o in self.OBJECTS.items() if p.rsplit("/", 1)[0] == path]
        if items and "watch=true" in query:
            return self.send(200, {"type": "ADDED", "object": items[0]})
        if items:
            return self.send(200, {"kind": items[0]["kind"] + "List",
                                   "apiVersion": items[0]["apiVersion"],
                                   "metadata": {"resourceVersion": "1"}, "items": items})
        self.send(404, {"kind": "Status", "apiVersion": "v1", "status": "Failure",
                        "reason": "NotFound", "code": 404, "message": f"{path} not found"})

    def do_PATCH(self):
        path = self.path.split("?")[0]
        body = self.rfile.read(int(self.headers.get("Content-Length", "0")))
        if path not in self.OBJECTS:
            return self.send(404, None)
        self.PATCHES.append((path, self.headers.get("Content-Type"), json.loads(body)))
        self.send(200, self.OBJECTS[path])

    def log_message(self, *args):
        pass


def containers(doc):
    return doc["spec"]["template"]["spec"]["containers"]


def documented_kubectl(repo):
    """docs/deploy.md's kubectl commands: its Kubernetes and batch sh blocks, and the inline
    `kubectl rollout restart`, as written."""
    text = doc_commands.read(repo)
    commands = []
    for needle in ("kubectl apply -f deploy/k8s/front.yaml", "kubectl wait"):
        for command, comment in doc_commands.block_with(text, needle):
            commands.append(command)
            # "kubectl apply -k deploy/k8s/overlays/cpu   # or overlays/gpu": both.
            m = re.match(r"or (\S+)", comment)
            if m and command.startswith("kubectl apply -k deploy/k8s/"):
                commands.append("kubectl apply -k deploy/k8s/" + m.group(1))
    commands += [c for c in doc_commands.inline_commands(text) if c.startswith("kubectl rollout")]
    return [c for c in commands if c.startswith("kubectl")]


def run_documented(kubectl, env, repo, work, docs):
    """Runs each of docs/deploy.md's kubectl commands against the stub: as written, with
    `--dry-run=client -o json` added to those that make objects (and --validate=false to apply:
    client-side validation would download the OpenAPI document; the k8s_schema test validates
    against it), `kubectl wait` and `kubectl rollout restart` as they are. The files they name
    exist where they run: the repository's paths from its root; tls.crt and tls.key (made by
    deploy/nginx/self-signed-cert.sh) and my-spec.json in a work directory."""
    subprocess.run([os.path.join(repo, "deploy", "nginx", "self-signed-cert.sh"), work, "1"],
                   check=True, capture_output=True)
    with open(os.path.join(work, "my-spec.json"), "w") as f:
        json.dump({"snapshot": {}, "cameras": [], "frame": "width=64&height=64&format=png"}, f)
    job = dict(docs[("batch-job.yaml", "Job")])
    job["metadata"] = dict(job["metadata"], namespace="default", resourceVersion="1")
    job["status"] = {"conditions": [{"type": "Complete", "status": "True"}]}
    front = dict(docs[("front.yaml", "Deployment")])
    front["metadata"] = dict(front["metadata"], namespace="default", resourceVersion="1")
    Discovery.OBJECTS = {"/apis/batch/v1/namespaces/default/jobs/myriad-batch": job,
                         "/apis/apps/v1/namespaces/default/deployments/myriad-front": front}
    Discovery.PATCHES = []
    front_spec = front["spec"]["template"]["spec"]
    job_spec = job["spec"]["template"]["spec"]
    commands = documented_kubectl(repo)
    check(len(commands) >= 8, f"docs/deploy.md: only {len(commands)} kubectl commands: {commands}")
    for command in commands:
        argv = command.split()
        cwd = repo
        if argv[1] == "apply":
            argv += ["--dry-run=client", "--validate=false", "-o", "name"]
        elif argv[1] == "create":
            argv += ["--dry-run=client", "-o", "json"]
            if argv[2] == "secret" or "my-spec.json" in command:
                cwd = work
        elif argv[1] == "kustomize":
            pass  # offline: the objects an overlay applies, checked below
        elif argv[1:3] not in (["wait", "--for=condition=complete"], ["rollout", "restart"]):
            check(False, f"k8s_test.py does not know how to run `{command}` (docs/deploy.md)")
            continue
        r = subprocess.run([kubectl] + argv[1:], capture_output=True, text=True, env=env,
                           cwd=cwd, timeout=60)
        shown = r.stdout if argv[1] not in ("create", "kustomize") else ""
        print(f"$ {command}\n  -> exit {r.returncode}: "
              f"{' '.join(shown.split())[:200]}"
              f"{r.stderr.strip()[:300] if r.returncode else ''}", flush=True)
        if not check(r.returncode == 0, f"`{command}`: {r.stderr.strip()}"):
            continue
        if argv[1] == "kustomize":
            import yaml  # python3-yaml
            source = os.path.relpath(argv[2], "deploy/k8s")
            made = sorted(d["kind"] for d in yaml.safe_load_all(r.stdout) if d)
            kinds = sorted(k for f, k in docs if f == source)
            check(made and made == kinds, f"`{command}`: {made}, expected {kinds}")
            print(f"  {made}", flush=True)
        elif argv[1] == "apply":
            option = "-f" if "-f" in argv else "-k"
            source = os.path.relpath(argv[argv.index(option) + 1], "deploy/k8s")
            kinds = sorted(k for f, k in docs if f == source)
            check(kinds, f"`{command}`: deploy/k8s/{source} is not a source the test knows")
            check(len(r.stdout.split()) == len(kinds), f"`{command}`: {r.stdout}, expected {kinds}")
        elif argv[1:3] == ["create", "secret"]:
            made = json.loads(r.stdout)
            check(made["type"] == "kubernetes.io/tls" and
                  sorted(made["data"]) == ["tls.crt", "tls.key"], f"`{command}`: {made}")
            mounted = [v["secret"]["secretName"] for v in front_spec["volumes"] if "secret" in v]
            check([made["metadata"]["name"]] == mounted,
                  f"the front mounts the secrets {mounted}, the document makes {made['metadata']}")
        elif argv[1:3] == ["create", "configmap"]:
            made = json.loads(r.stdout)
            name, keys = made["metadata"]["name"], sorted(made["data"])
            mounts = {"myriad-front": front_spec, "myriad-batch-spec": job_spec}
            check(name in mounts, f"`{command}`: no manifest mounts a ConfigMap {name}")
            volumes = [v["configMap"] for v in mounts.get(name, {}).get("volumes", [])
                       if v.get("configMap", {}).get("name") == name]
            wanted = sorted({i["key"] for v in volumes for i in v.get("items", [])}) or None
            check(volumes and (wanted is None or wanted == keys),
                  f"`{command}`: the manifest mounts {wanted} of {name}, the ConfigMap holds {keys}")
            print(f"  configmap {name}: {keys}", flush=True)
            if name == "myriad-batch-spec":
                mount = [m["mountPath"] for m in job_spec["containers"][0]["volumeMounts"]
                         if m["name"] in [v["name"] for v in job_spec["volumes"]
                                          if v.get("configMap", {}).get("name") == name]]
                check(mount and f"--batch={mount[0]}/{keys[0]}" in job_spec["containers"][0]["args"],
                      f"the Job's --batch does not read {keys} where {name} is mounted ({mount})")
        elif argv[1] == "wait":
            check("condition met" in r.stdout, f"`{command}`: {r.stdout}")
        elif argv[1] == "rollout":
            patched = [p for p in Discovery.PATCHES if p[0].endswith("/deployments/myriad-front")]
            check(patched and "kubectl.kubernetes.io/restartedAt" in json.dumps(patched[-1][2]),
                  f"`{command}` did not patch the front's pod template: {Discovery.PATCHES}")


def workloads(docs):
    return {(source, kind): d for (source, kind), d in docs.items()
            if kind in ("Deployment", "StatefulSet", "Job")}


def selects(selector, labels):
    wanted = (selector or {}).get("matchLabels") or {}
    return bool(wanted) and all(labels.get(k) == v for k, v in wanted.items())


def check_issue33(docs, sources, version):
    """Pinned images, resources, disruption budgets, GPU scheduling (the module's docstring)."""
    for (source, kind), d in workloads(docs).items():
        for c in containers(d):
            for problem in k8s_sources.image_problems(c.get("image", ""), version):
                check(False, f"{source} {kind} container {c['name']}: {problem}")
            res = c.get("resources") or {}
            for part in ("requests", "limits"):
                missing = [r for r in ("cpu", "memory") if r not in (res.get(part) or {})]
                check(not missing, f"{source} {kind} container {c['name']}: no {part} {missing}")
    budgets = 0
    for (source, kind), d in workloads(docs).items():
        replicas = d["spec"].get("replicas", 1)
        if kind == "Job" or replicas < 2:
            continue
        labels = d["spec"]["template"]["metadata"].get("labels") or {}
        pdbs = [p for (s2, k2), p in docs.items()
                if s2 == source and k2 == "PodDisruptionBudget" and
                selects(p["spec"].get("selector"), labels)]
        if not check(len(pdbs) == 1, f"{source}: {len(pdbs)} PodDisruptionBudgets select the pods "
                                     f"of {kind} {d['metadata']['name']}, expected 1"):
            continue
        spec = pdbs[0]["spec"]
        check(pdbs[0]["apiVersion"] == "policy/v1", f"{source}: the budget is not policy/v1")
        check(isinstance(spec.get("maxUnavailable", spec.get("minAvailable")), int),
              f"{source}: the budget's figure is not a number of pods: {spec}")
        can_go = (spec["maxUnavailable"] if "maxUnavailable" in spec
                  else replicas - spec["minAvailable"])
        check(1 <= can_go < replicas, f"{source}: the budget of {kind} {d['metadata']['name']} "
              f"({spec}) lets {can_go} of {replicas} pods go: at least one, not all")
        budgets += 1
        print(f"{source}: {kind} {d['metadata']['name']} x{replicas}, budget {spec}", flush=True)
    check(budgets >= 2, f"only {budgets} replicated workloads under a budget (nodes, front)")
    for source in sources:
        s = docs.get((source, "StatefulSet"))
        if s is None:
            continue
        pod = s["spec"]["template"]["spec"]
        c = pod["containers"][0]
        gpu = "gpu" in os.path.basename(source)
        limit = c["resources"]["limits"].get("nvidia.com/gpu")
        tolerated = [t for t in pod.get("tolerations") or [] if t.get("key") == "nvidia.com/gpu"]
        selector = pod.get("nodeSelector") or {}
        if gpu:
            check(limit == 1, f"{source}: GPU variant without a GPU (limits {c['resources']})")
            check("--device=NVIDIA" in [a.split()[0] for a in c["args"]],
                  f"{source}: GPU variant without --device=NVIDIA")
            check(any(k.startswith("nvidia.com/") for k in selector),
                  f"{source}: GPU variant without a GPU nodeSelector: {selector}")
            check(tolerated and all(t.get("operator") == "Exists" or "value" in t
                                    for t in tolerated),
                  f"{source}: GPU variant does not tolerate the nvidia.com/gpu taint: "
                  f"{pod.get('tolerations')}")
            check("LP_NUM_THREADS" not in [e["name"] for e in c.get("env", [])],
                  f"{source}: lavapipe's LP_NUM_THREADS on a GPU pod")
        else:
            check(limit is None and not tolerated and not selector.get("nvidia.com/gpu.present"),
                  f"{source}: the CPU variant asks for GPUs or GPU nodes")
        print(f"{source}: nodeSelector {selector}, tolerations {pod.get('tolerations')}, "
              f"limits {c['resources']['limits']}, image {c['image']}", flush=True)


def main():
    server, repo = sys.argv[1], sys.argv[2]
    import yaml  # python3-yaml

    k8s = os.path.join(repo, "deploy", "k8s")
    kubectl = shutil.which("kubectl")
    help_text = subprocess.run([server, "--help"], capture_output=True, text=True).stdout
    flags = set(re.findall(r"^\s+(--[a-z-]+)", help_text, re.M))
    version = k8s_sources.project_version(repo)
    check(version, "CMakeLists.txt names no project version (the image tag)")
    # The files applied with -f and the kustomizations rendered, or without kubectl the base's
    # file as it is (the CPU variant).
    kustomized = k8s_sources.kustomizations(repo)
    check(set(kustomized) >= {"base", "overlays/cpu", "overlays/gpu"},
          f"deploy/k8s: kustomizations {kustomized}, expected base, overlays/cpu, overlays/gpu")
    sources = k8s_sources.files(repo) + (kustomized if kubectl else ["base/myriad.yaml"])
    variants = k8s_sources.overlays(repo) if kubectl else ["base/myriad.yaml"]
    docs = {}
    for source in sources:
        try:
            loaded = [d for d in yaml.safe_load_all(k8s_sources.text(repo, kubectl, source)) if d]
        except (RuntimeError, yaml.YAMLError) as e:
            check(False, f"deploy/k8s/{source}: {e}")
            continue
        check(loaded, f"deploy/k8s/{source} holds no object")
        for d in loaded:
            check(all(k in d for k in ("apiVersion", "kind", "metadata")),
                  f"{source}: an object without apiVersion/kind/metadata")
            check((source, d.get("kind")) not in docs,
                  f"{source}: two objects of kind {d.get('kind')}")
            docs[(source, d["kind"])] = d
    print(f"{len(sources)} sources, {len(docs)} objects: "
          f"{sorted(f'{f}:{k}' for f, k in docs)}", flush=True)
    # Every file under the kustomizations is a kustomization or named by one (no manifest left
    # that no command applies).
    named = k8s_sources.referenced(repo, yaml)
    for path in glob.glob(os.path.join(k8s, "*", "**", "*.yaml"), recursive=True):
        rel = os.path.relpath(path, k8s)
        check(os.path.basename(rel) == "kustomization.yaml" or rel in named,
              f"deploy/k8s/{rel} is named by no kustomization.yaml")

    # The pods' flags exist; the probes ask the server's routes.
    for (name, kind), d in docs.items():
        if kind not in ("StatefulSet", "Job"):
            continue
        for c in containers(d):
            for arg in c.get("args", []):
                flag = arg.split("=")[0]
                if flag.startswith("--"):
                    check(flag in flags, f"{name}: {flag} is not a myriad-server flag")
    for variant in variants:
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
        replicas = s["spec"]["replicas"]
        nodes = [f"{i}=myriad-{i}.myriad-nodes:8080" for i in range(replicas)]
        expected = subprocess.run([os.path.join(repo, "deploy", "nginx", "upstreams.sh")] + nodes,
                                  capture_output=True, text=True, check=True).stdout
        with open(os.path.join(k8s, "upstreams.conf")) as f:
            check(f.read() == expected,
                  f"deploy/k8s/upstreams.conf is not upstreams.sh's output for {replicas} replicas")
    if kubectl:
        check_issue33(docs, variants, version)
        gpu = [v for v in variants if "gpu" in v]
        check(len(gpu) == 1 and len(variants) == 2, f"overlays {variants}: one CPU, one GPU")
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
        for source in sources:
            option = "-f" if source.endswith(".yaml") else "-k"
            path = os.path.join("deploy", "k8s", source)
            r = subprocess.run([kubectl, "create", "--dry-run=client", "--validate=false", option,
                                path, "-o", "name"], capture_output=True, text=True, env=env,
                               timeout=60, cwd=repo)
            names = r.stdout.split()
            print(f"kubectl create --dry-run=client {option} {path}: "
                  f"exit {r.returncode}, {names}", flush=True)
            check(r.returncode == 0, f"kubectl refuses {path}: {r.stderr.strip()}")
            kinds = sorted(kind for f, kind in docs if f == source)
            check(len(names) == len(kinds), f"{path}: kubectl made {names}, the source has {kinds}")
        run_documented(kubectl, env, repo, work, docs)
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
