#!/usr/bin/env python3
"""deploy/k8s against the Kubernetes OpenAPI schemas, offline: what `kubectl apply
--dry-run=server` checks of an object's shape, without a cluster. The objects are those of the
files applied with -f (deploy/k8s/*.yaml) and of every kustomization (base, overlays/cpu,
overlays/gpu) as `kubectl kustomize` renders it, which is what `kubectl apply -k` sends
(k8s_sources.py); without kubectl only the files and the base's manifest are validated, and the
test ends in a skip.

The schemas are the definitions of the upstream Kubernetes OpenAPI document (v1.33.0) as the npm
package kubernetes-models compiles them (ajv validate functions), pinned by
tests/k8s-schema/package-lock.json and installed there by `npm ci` (scripts/test.sh).
tests/k8s-schema/validate.mjs validates each object against the schema of its apiVersion and kind:
types and formats (int32, ...), required fields, enums, and, as the API server's strict field
validation does (the default of `kubectl apply` since 1.27), no field the schema does not declare.
Documents are read by python3-yaml as kubectl reads them, with a key given twice in one mapping an
error (strict decoding refuses it too).

So that a green run means something, the test also validates deliberately broken copies of the
real objects, built in memory, and requires each to be refused with a message naming the broken
field: an unknown field in a container, a string port, a Deployment and a StatefulSet without
`selector`, `replicas: "two"`, values outside an enum, an undeclared field in metadata, a
PodDisruptionBudget (policy/v1) with a list for a count, a policy outside the enum, both
minAvailable and maxUnavailable, and a GPU toleration with an operator outside the enum.

Usage: k8s_schema_test.py REPO_ROOT. Exit 0 pass, 1 fail, 77 skip (no node, or no kubectl to
render the kustomizations).
"""
import copy
import json
import os
import re
import shutil
import subprocess
import sys
import time

import yaml  # python3-yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import k8s_sources  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from server_script import check, failures  # noqa: E402


class StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice in one mapping, as strict decoding does."""


def _mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f'duplicate field "{key}"', key_node.start_mark)
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep)


StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                             lambda loader, node: _mapping(loader, node, True))


def load_all(text):
    return [d for d in yaml.load_all(text, Loader=StrictLoader) if d is not None]


def validate(validator, objects):
    r = subprocess.run(["node", validator], input=json.dumps(objects), capture_output=True,
                       text=True, timeout=60)
    if r.returncode != 0:
        raise RuntimeError(f"validate.mjs exit {r.returncode}: {r.stderr.strip()}")
    return json.loads(r.stdout)


def containers(doc):
    return doc["spec"]["template"]["spec"]["containers"]


def main():
    repo = sys.argv[1]
    schema_dir = os.path.join(repo, "tests", "k8s-schema")
    validator = os.path.join(schema_dir, "validate.mjs")
    if shutil.which("node") is None:
        print("SKIP: node is not installed (scripts/install-deps.sh --with-test-tools)")
        return 77
    if not os.path.isdir(os.path.join(schema_dir, "node_modules", "kubernetes-models")):
        print("FAIL: tests/k8s-schema/node_modules is missing: run `npm ci` in tests/k8s-schema "
              "(scripts/test.sh does)")
        return 1
    with open(os.path.join(schema_dir, "node_modules", "kubernetes-models", "package.json")) as f:
        print(f"kubernetes-models {json.load(f)['version']} (Kubernetes v1.33.0 OpenAPI)", flush=True)

    # Every document of every source: the files, and the kustomizations rendered.
    started = time.monotonic()
    kubectl = shutil.which("kubectl")
    if kubectl is None:
        print("kubectl is not installed (scripts/install-deps.sh --with-test-tools): the "
              "kustomizations are not rendered, base/myriad.yaml is validated as it is", flush=True)
    sources = k8s_sources.files(repo) + (k8s_sources.kustomizations(repo) if kubectl
                                         else ["base/myriad.yaml"])
    cpu = "overlays/cpu" if kubectl else "base/myriad.yaml"
    gpu = "overlays/gpu" if kubectl else "base/myriad.yaml"
    objects, where = [], []
    for source in sources:
        name = f"deploy/k8s/{source}"
        try:
            docs = load_all(k8s_sources.text(repo, kubectl, source))
        except (RuntimeError, yaml.YAMLError) as e:
            check(False, f"{name}: {e}")
            continue
        check(docs, f"{name} holds no object")
        for d in docs:
            objects.append(d)
            where.append(f"{name}: {d.get('kind')}/{(d.get('metadata') or {}).get('name')}")
    kinds = sorted({(d.get("apiVersion"), d.get("kind")) for d in objects})
    print(f"{len(objects)} objects, kinds {kinds}", flush=True)
    for label, result in zip(where, validate(validator, objects)):
        if check(not result["errors"], f"{label} is refused: {result['errors']}"):
            print(f"ok   {label} ({result['schema']})", flush=True)

    def find(source, kind):
        for label, d in zip(where, objects):
            if label.startswith(f"deploy/k8s/{source}: {kind}/"):
                return copy.deepcopy(d)
        raise KeyError(f"{source} has no {kind}")

    # Two rules of the API server's validation that no schema can state, which a server-side dry
    # run would apply: a workload's selector selects its own pod template (else "selector does not
    # match template labels"), and each Service selects the pods of a workload of the same file.
    def selector_errors(d):
        spec = d.get("spec") or {}
        if d.get("kind") not in ("Deployment", "StatefulSet") or "selector" not in spec:
            return []
        wanted = (spec["selector"] or {}).get("matchLabels") or {}
        labels = ((spec.get("template") or {}).get("metadata") or {}).get("labels") or {}
        if not wanted or any(labels.get(k) != v for k, v in wanted.items()):
            return [f"spec.template.metadata.labels: Invalid value: {labels}: "
                    f"`selector` does not match template `labels`"]
        return []

    # And of a PodDisruptionBudget: minAvailable or maxUnavailable, not both ("minAvailable and
    # maxUnavailable cannot be both set"), each a count or a percentage.
    def budget_errors(d):
        if d.get("kind") != "PodDisruptionBudget":
            return []
        spec = d.get("spec") or {}
        given = [k for k in ("minAvailable", "maxUnavailable") if k in spec]
        errors = []
        if len(given) == 2:
            errors.append("spec: Invalid value: minAvailable and maxUnavailable cannot be both set")
        for k in given:
            v = spec[k]
            if (isinstance(v, str) and not re.fullmatch(r"[0-9]+%", v)) or (
                    isinstance(v, int) and v < 0):
                errors.append(f"spec.{k}: Invalid value: {v!r}: a count or a percentage")
        return errors

    budgets = 0
    for label, d in zip(where, objects):
        check(not selector_errors(d), f"{label}: {selector_errors(d)}")
        check(not budget_errors(d), f"{label}: {budget_errors(d)}")
        if d.get("kind") in ("Service", "PodDisruptionBudget"):
            spec = d.get("spec") or {}
            selector = (spec.get("selector") or {}) if d["kind"] == "Service" else \
                ((spec.get("selector") or {}).get("matchLabels") or {})
            file = label.split(":")[0]
            pods = [w["spec"]["template"]["metadata"].get("labels") or {}
                    for l, w in zip(where, objects)
                    if l.split(":")[0] == file and w.get("kind") in ("Deployment", "StatefulSet")]
            check(selector and any(all(p.get(k) == v for k, v in selector.items()) for p in pods),
                  f"{label}: its selector {selector} selects no pod template of {file}")
            budgets += d["kind"] == "PodDisruptionBudget"
    check(budgets >= 2, f"only {budgets} PodDisruptionBudgets (the nodes', the front's)")
    broken = find(cpu, "PodDisruptionBudget")
    broken["spec"]["minAvailable"] = 2
    check(budget_errors(broken), "a budget with minAvailable and maxUnavailable passed")
    print(f"broken: a budget with both figures: {budget_errors(broken)}", flush=True)
    broken = find(cpu, "StatefulSet")
    broken["spec"]["template"]["metadata"]["labels"] = {"app": "other"}
    check(selector_errors(broken), "a StatefulSet whose selector misses its template passed")
    print(f"broken: a selector that misses the template: {selector_errors(broken)}", flush=True)

    # Broken copies: each must be refused, every message naming the broken field.
    cases = []

    def case(what, file, kind, change, field):
        d = find(file, kind)
        change(d)
        cases.append((what, d, field))

    case("an unknown field in a container (livenessprobe for livenessProbe)", cpu,
         "StatefulSet", lambda d: containers(d)[0].__setitem__(
             "livenessprobe", containers(d)[0]["livenessProbe"]),
         'unknown field "spec.template.spec.containers[0].livenessprobe"')
    case("a string where the container port's integer belongs", gpu, "StatefulSet",
         lambda d: containers(d)[0]["ports"][0].__setitem__("containerPort", "8080"),
         "spec.template.spec.containers[0].ports[0].containerPort")
    case("a Deployment without selector", "front.yaml", "Deployment",
         lambda d: d["spec"].pop("selector"), "spec.selector")
    case("a StatefulSet without selector", cpu, "StatefulSet",
         lambda d: d["spec"].pop("selector"), "spec.selector")
    case('replicas: "two"', cpu, "StatefulSet",
         lambda d: d["spec"].__setitem__("replicas", "two"), "spec.replicas")
    case("a Service type outside the enum", "front.yaml", "Service",
         lambda d: d["spec"].__setitem__("type", "LoadBalancr"), "spec.type")
    case("a Job completionMode outside the enum", "batch-job.yaml", "Job",
         lambda d: d["spec"].__setitem__("completionMode", "Indexd"), "spec.completionMode")
    case("an undeclared field in metadata (lables)", "front.yaml", "Deployment",
         lambda d: d["metadata"].__setitem__("lables", {"app": "x"}),
         'unknown field "metadata.lables"')
    case("a probe's port as a list", cpu, "StatefulSet",
         lambda d: containers(d)[0]["readinessProbe"]["httpGet"].__setitem__("port", [8080]),
         "spec.template.spec.containers[0].readinessProbe.httpGet.port")
    case("a volume mount without mountPath", "batch-job.yaml", "Job",
         lambda d: containers(d)[0]["volumeMounts"][0].pop("mountPath"),
         "spec.template.spec.containers[0].volumeMounts[0].mountPath")
    case("a kind the group does not have", cpu, "StatefulSet",
         lambda d: d.__setitem__("kind", "StatefulSets"), 'no kind "StatefulSets" in "apps/v1"')
    case("a budget's count as a list", cpu, "PodDisruptionBudget",
         lambda d: d["spec"].__setitem__("maxUnavailable", [1]), "spec.maxUnavailable")
    case("a budget's eviction policy outside the enum", cpu, "PodDisruptionBudget",
         lambda d: d["spec"].__setitem__("unhealthyPodEvictionPolicy", "Always"),
         "spec.unhealthyPodEvictionPolicy")
    case("an undeclared field in a budget (maxUnavaliable)", "front.yaml", "PodDisruptionBudget",
         lambda d: d["spec"].__setitem__("maxUnavaliable", 1),
         'unknown field "spec.maxUnavaliable"')
    case("a GPU toleration's operator outside the enum", gpu, "StatefulSet",
         lambda d: d["spec"]["template"]["spec"].__setitem__(
             "tolerations", [{"key": "nvidia.com/gpu", "operator": "Exist",
                              "effect": "NoSchedule"}]),
         "spec.template.spec.tolerations[0].operator")
    results = validate(validator, [d for _, d, _ in cases])
    for (what, _, field), result in zip(cases, results):
        errors = result["errors"]
        print(f"broken: {what}: {errors}", flush=True)
        check(errors, f"not refused: {what}")
        check(errors and all(field in e for e in errors),
              f"{what}: expected every message to name {field}, got {errors}")

    # A key given twice is refused by the loader, as by the API server's strict decoding.
    try:
        load_all("apiVersion: v1\nkind: Service\nmetadata: {name: a}\nspec: {type: ClusterIP}\n"
                 "spec: {type: NodePort}\n")
        check(False, "a duplicate field was accepted")
    except yaml.YAMLError as e:
        print(f"broken: a duplicate field: {str(e).splitlines()[0]}", flush=True)
        check('duplicate field "spec"' in str(e), f"duplicate field message: {e}")

    print(f"validated {len(objects)} objects and {len(cases)} broken copies in "
          f"{time.monotonic() - started:.1f} s", flush=True)
    if failures:
        print(f"{len(failures)} failure(s)")
        return 1
    if kubectl is None:
        print("SKIP: the kustomizations were not rendered (no kubectl); the rest passed")
        return 77
    print("PASS")
    return 0


if __name__ == "__main__":
    sys.exit(main())
