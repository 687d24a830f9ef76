"""The README's Python examples run as written, on the synthetic scene, with small NumPy arrays
standing in for the PyTorch models' outputs (PyTorch is not installed where the tests run)."""

from __future__ import annotations

import re
import shutil

import numpy as np

from conftest import WORKSPACE
from test_merge import view_inputs


def readme_blocks():
    text = (WORKSPACE / "README.md").read_text()
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def block_calling(name: str) -> str:
    found = [b for b in readme_blocks() if f"splatseg.{name}(" in b]
    assert len(found) == 1, f"one README example calls splatseg.{name}: {len(found)}"
    return found[0]


class FakeTensor:
    """What the example calls on DINOv2's output tensor: indexing, reshape, float, cpu, numpy."""

    def __init__(self, array: np.ndarray):
        self.array = array

    def __getitem__(self, index):
        return FakeTensor(self.array[index])

    def reshape(self, *shape):
        return FakeTensor(self.array.reshape(*shape))

    def float(self):
        return FakeTensor(self.array.astype(np.float32))

    def cpu(self):
        return self

    def numpy(self):
        return self.array


def test_readme_merge_view_example_runs(scene, stems, capsys):
    masks, image, features, depth = view_inputs(scene, stems[0])
    h, w, c = features.shape
    tokens = FakeTensor(features.reshape(1, h * w, c).astype(np.float16))  # as a half-precision model gives
    namespace = {"masks": masks, "image": image, "tokens": tokens, "h": h, "w": w, "depth": depth}
    exec(compile(block_calling("merge_view"), "README.md (merge_view example)", "exec"), namespace)
    regions = namespace["regions"]
    assert regions.shape == image.shape[:2] and regions.dtype == np.uint32 and regions.max() > 1
    assert "SAM masks ->" in capsys.readouterr().out


def test_readme_run_example_runs(scene, tmp_path, monkeypatch):
    garden = tmp_path / "garden"
    shutil.copytree(scene, garden, ignore=shutil.ignore_patterns("gaussians.ply", "features"))
    shutil.copy(scene / "gaussians.ply", garden / "splat.ply")
    shutil.copytree(scene / "features", garden / "dinov2")
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block_calling("run"), "README.md (run example)", "exec"), namespace)
    result = namespace["result"]
    assert (tmp_path / "garden_objects" / "report.md").read_text() == result.report
    chair = (tmp_path / "chair.ply").read_bytes()
    count = max(o["gaussian_count"] for o in result.objects)
    assert f"element vertex {count}\n".encode() in chair[:2000]


def test_readme_apply_edits_example_runs(scene, tmp_path, monkeypatch, capsys):
    """The edits example, on the run example's folder, with two of its ids in place of 3 and 7."""
    test_readme_run_example_runs(scene, tmp_path, monkeypatch)
    ids = [int(i) for i in np.unique(splatseg_ids(tmp_path / "garden_objects")) if i > 0]
    a, b = ids[0], ids[1]
    block = block_calling("apply_edits").replace("[3, 7]", f"[{a}, {b}]").replace('"id": 3', f'"id": {a}')
    namespace: dict = {}
    exec(compile(block, "README.md (apply_edits example)", "exec"), namespace)
    edited = namespace["edited"]
    assert [o["id"] for o in edited.objects if o.get("name") == "chair"] == [a]
    assert b not in edited.object_ids and edited.applied["operations"] == 2
    assert "'name': 'chair'" in capsys.readouterr().out


def splatseg_ids(out):
    import splatseg

    return splatseg.read_ply(out / "gaussians.ply")["object_ids"]
