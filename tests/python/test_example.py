"""client/python/examples/synthetic_data.py, run as a user runs it, against the test server."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
from PIL import Image

EXAMPLE = Path(__file__).resolve().parents[2] / "client" / "python" / "examples" / \
    "synthetic_data.py"


def test_synthetic_data_example_writes_a_dataset(server, client, tmp_path):
    open_before = client.info()["sessions"]["open"]
    out = tmp_path / "dataset"
    result = subprocess.run([sys.executable, str(EXAMPLE), "--url", server.url, "--out",
                             str(out), "--frames", "6", "--size", "64x48", "--concurrency", "2"],
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("6 frames of 64x48 in ")
    document = json.loads((out / "metadata.json").read_text())
    assert [f["index"] for f in document["frames"]] == list(range(6))
    last = document["frames"][5]
    assert set(last["files"]) == {"final", "depth", "normal", "instance-id"}
    with Image.open(out / last["files"]["final"]) as final:
        assert final.size == (64, 48) and np.asarray(final).max() > 0
    depth = np.load(out / last["files"]["depth"])
    assert depth.shape == (48, 64) and (depth < last["far"]).any()
    eyes = [np.array(f["world_from_camera"])[:3, 3] for f in document["frames"]]
    assert len({tuple(np.round(e, 4)) for e in eyes}) == 6  # an orbit: six places
    assert client.info()["sessions"]["open"] == open_before  # the example's session is gone


def test_the_readme_example_runs(server, client):
    readme = (EXAMPLE.parents[1] / "README.md").read_text()
    code = readme.split("```python\n", 1)[1].split("```", 1)[0]
    assert len(code.strip().splitlines()) == 5
    code = code.replace("http://127.0.0.1:8080", server.url)
    open_before = client.info()["sessions"]["open"]
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("(360, 640, 3) float32 [[")
    assert client.info()["sessions"]["open"] == open_before
