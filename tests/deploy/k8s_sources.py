"""What the k8s tests (k8s_test.py, k8s_schema_test.py) read of deploy/k8s: the objects each thing
docs/deploy.md applies would make.

deploy/k8s holds two kinds of sources:
  - files applied as they are (`kubectl apply -f deploy/k8s/front.yaml`): deploy/k8s/*.yaml;
  - kustomizations (`kubectl apply -k deploy/k8s/overlays/cpu`): every directory with a
    kustomization.yaml (base, overlays/cpu, overlays/gpu), rendered by `kubectl kustomize DIR`
    (kubectl's built-in kustomize: 2.0 in Debian 12's kubectl 1.20, 5.x in current ones; offline).
A source is named by its path under deploy/k8s: "front.yaml", "overlays/gpu".
"""
import glob
import os
import re
import subprocess


def k8s_dir(repo):
    return os.path.join(repo, "deploy", "k8s")


def files(repo):
    """The files applied with -f: deploy/k8s/*.yaml, by source name."""
    return sorted(os.path.basename(p) for p in glob.glob(os.path.join(k8s_dir(repo), "*.yaml")))


def kustomizations(repo):
    """The directories applied with -k (or built on by one): source names such as "overlays/cpu"."""
    root = k8s_dir(repo)
    found = glob.glob(os.path.join(root, "**", "kustomization.yaml"), recursive=True)
    return sorted(os.path.relpath(os.path.dirname(p), root) for p in found)


def overlays(repo):
    return [k for k in kustomizations(repo) if k.startswith("overlays/")]


def render(kubectl, repo, source):
    """`kubectl kustomize deploy/k8s/SOURCE`: (returncode, YAML text, stderr). kustomize 5 warns on
    stderr about the fields kept for kustomize 2.0 (bases, patchesStrategicMerge): not errors."""
    r = subprocess.run([kubectl, "kustomize", os.path.join(k8s_dir(repo), source)],
                       capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, HOME=os.environ.get("HOME", "/tmp")))
    return r.returncode, r.stdout, r.stderr


def text(repo, kubectl, source):
    """The YAML of a source: the file's text, or the kustomization rendered (RuntimeError when
    kubectl fails)."""
    if source.endswith(".yaml"):
        with open(os.path.join(k8s_dir(repo), source)) as f:
            return f.read()
    code, out, err = render(kubectl, repo, source)
    if code != 0:
        raise RuntimeError(f"kubectl kustomize deploy/k8s/{source}: exit {code}: {err.strip()}")
    return out


def referenced(repo, yaml):
    """Every file a kustomization names (resources, patchesStrategicMerge, patches' paths), as
    paths under deploy/k8s; kustomizations it builds on (bases) are directories and left out."""
    root = k8s_dir(repo)
    named = set()
    for k in kustomizations(repo):
        with open(os.path.join(root, k, "kustomization.yaml")) as f:
            spec = yaml.safe_load(f) or {}
        entries = list(spec.get("resources") or []) + list(spec.get("patchesStrategicMerge") or [])
        entries += [p["path"] for p in spec.get("patches") or [] if "path" in p]
        for e in entries:
            path = os.path.normpath(os.path.join(root, k, e))
            if os.path.isfile(path):
                named.add(os.path.relpath(path, root))
    return named


def project_version(repo):
    """The project's version (CMakeLists.txt `project(Myriad VERSION x.y.z ...)`): the image tag."""
    with open(os.path.join(repo, "CMakeLists.txt")) as f:
        m = re.search(r"project\(\s*Myriad\s+VERSION\s+([0-9.]+)", f.read())
    return m.group(1) if m else None


def image_problems(image, version):
    """What is wrong with a container's image reference: no tag or :latest (not pinned), or a
    Myriad image not tagged with the project's version."""
    name, _, digest = image.partition("@")
    last = name.rsplit("/", 1)[-1]
    tag = last.partition(":")[2]
    if digest:
        return []
    if not tag or tag == "latest":
        return [f"image {image} is not pinned (a tag other than latest, or a digest)"]
    if last.partition(":")[0] == "myriad" and version and tag != version:
        return [f"image {image}: the release is {version} (CMakeLists.txt)"]
    return []
