"""splatseg.apply_edits against `splatseg apply`: a merge and a rename applied to a small run, the
rest of the package (run, read_ply, extract) seeing the edited objects and names, and bad edits
raising with the command line's message while nothing changes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import splatseg
from conftest import cli
from helpers import read_ply_columns, read_png


def fresh_run(workdir: Path, scene: Path, name: str) -> Path:
    """`splatseg run` on the scene with features into a folder of its own (the edits change it)."""
    out = workdir / name
    cli("run", scene, "--masks", scene / "sam", "--features", scene / "features", "--out", out)
    return out


def two_largest(ids: np.ndarray):
    labels, counts = np.unique(ids[ids > 0], return_counts=True)
    order = np.argsort(-counts, kind="stable")
    return int(labels[order[0]]), int(labels[order[1]])


def write_edits(out: Path, operations, inputs=None, version=1) -> Path:
    path = out / "edits.json"
    edits = {"version": version, "inputs": inputs or splatseg.edit_inputs(out), "operations": operations}
    path.write_text(json.dumps(edits, indent=2))
    return path


def outputs(out: Path) -> dict:
    """Every file outside cache/ with its bytes (edits.json, the input, and the lock left out)."""
    skip = lambda rel: rel.startswith("cache/") or rel in ("edits.json", ".splatseg.lock")  # noqa: E731
    return {
        str(p.relative_to(out)): p.read_bytes()
        for p in sorted(out.rglob("*"))
        if p.is_file() and not skip(str(p.relative_to(out)))
    }


def test_edit_inputs_name_the_runs_ply_and_key(workdir, scene):
    out = fresh_run(workdir, scene, "apply_inputs")
    inputs = splatseg.edit_inputs(out)
    _, rows = read_ply_columns(out / "gaussians.ply")
    assert inputs["gaussians"] == len(rows)
    assert inputs["run"] == json.loads((out / "cache" / "run.json").read_text())["key"]
    assert len(inputs["ply_digest"]) == 16
    with pytest.raises(ValueError, match="no finished run here"):
        splatseg.edit_inputs(workdir / "no_run_here")


def test_apply_edits_merges_and_names_as_the_command_line(workdir, scene):
    out = fresh_run(workdir, scene, "apply_merge")
    _, rows = read_ply_columns(out / "gaussians.ply")
    before = rows["object_id"].copy()
    a, b = two_largest(before)
    into, gone = min(a, b), max(a, b)
    write_edits(out, [{"op": "merge", "ids": [a, b]}, {"op": "rename", "id": into, "name": "the pair"}])

    result = splatseg.apply_edits(out)

    expected = np.where(before == gone, into, before).astype(np.int32)
    assert result.object_ids.dtype == np.int32
    np.testing.assert_array_equal(result.object_ids, expected)
    _, edited_rows = read_ply_columns(out / "gaussians.ply")
    np.testing.assert_array_equal(edited_rows["object_id"], expected)
    assert result.applied == {
        "operations": 2,
        "changed_gaussians": int((before == gone).sum()),
        "objects": len(result.objects),
        "names": 1,
        "views": len(result.label_maps),
    }
    for stem, got in result.label_maps.items():
        np.testing.assert_array_equal(got, read_png(out / "masks" / f"{stem}.png"), err_msg=stem)
        assert not (got == gone).any(), f"view {stem} still shows {gone}"
    assert any((m == into).any() for m in result.label_maps.values())
    named = [o for o in result.objects if "name" in o]
    assert [(o["id"], o["name"]) for o in named] == [(into, "the pair")]
    assert named[0]["gaussian_count"] == int((expected == into).sum())
    # The same table as `splatseg objects --json` on the edited PLY (names from objects.json).
    table = json.loads(cli("objects", out / "gaussians.ply", "--json"))
    assert result.objects == table["objects"]
    assert result.report == (out / "report.md").read_text() and "Edits (splatseg apply)" in result.report

    # The rest of the package sees the edits: read_ply's ids, extract by them, and run on the
    # folder (its inputs unchanged, so nothing is recomputed) reads the edited outputs with names.
    g = splatseg.read_ply(out / "gaussians.ply")
    np.testing.assert_array_equal(g["object_ids"], expected)
    assert len(splatseg.extract(g, into)["means"]) == int((expected == into).sum())
    again = splatseg.run(scene, masks=scene / "sam", features=scene / "features", out=out)
    np.testing.assert_array_equal(again.object_ids, expected)
    assert again.objects == result.objects and again.applied is None
    for stem, got in again.label_maps.items():
        np.testing.assert_array_equal(got, result.label_maps[stem], err_msg=stem)

    # Applied again, from the run's own result: the same bytes.
    files = outputs(out)
    splatseg.apply_edits(out)
    assert outputs(out) == files


def test_bad_edits_raise_with_the_command_lines_message_and_change_nothing(workdir, scene):
    out = fresh_run(workdir, scene, "apply_bad")
    _, rows = read_ply_columns(out / "gaussians.ply")
    absent = int(rows["object_id"].max()) + 5
    n = len(rows)
    inputs = splatseg.edit_inputs(out)
    other_ply = dict(inputs, ply_digest="0123456789abcdef")
    before = outputs(out)
    cases = [
        (lambda: write_edits(out, [{"op": "merge", "ids": [1, absent]}]), rf"operation 0 \(merge\): no object has id {absent}"),
        (lambda: write_edits(out, [{"op": "assign", "ranges": [[n - 1, n + 3]], "id": 1}]), "is not a non-empty range"),
        (lambda: (out / "edits.json").write_text('{"version": 1, "operations": ['), "not a valid edits file"),
        (lambda: write_edits(out, [], version=99), "written by a later splatseg"),
        (lambda: write_edits(out, [], inputs=other_ply), "made on a PLY with digest 0123456789abcdef"),
    ]
    for write, message in cases:
        write()
        with pytest.raises(ValueError, match=message) as raised:
            splatseg.apply_edits(out)
        assert str(out / "edits.json") in str(raised.value), raised.value
        assert outputs(out) == before, f"{message}: the outputs changed"
    (out / "edits.json").unlink()
    with pytest.raises(FileNotFoundError, match="edits.json"):
        splatseg.apply_edits(out)
    assert outputs(out) == before
