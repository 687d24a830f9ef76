"""splatseg.run against `splatseg run` on a synthetic scene."""

from __future__ import annotations

import json
import logging
import tempfile
from pathlib import Path

import numpy as np
import pytest

import splatseg
from conftest import cli
from helpers import read_ply_columns, read_png

OUTPUTS = ["gaussians.ply", "report.md", "metrics.json"]


def test_run_label_maps_equal_the_command_lines(run_outputs, stems):
    by_cli, result = run_outputs
    assert sorted(result.label_maps) == stems
    for stem in stems:
        expected = read_png(by_cli / "masks" / f"{stem}.png")
        got = result.label_maps[stem]
        assert got.dtype == np.uint16 and got.shape == expected.shape, (got.dtype, got.shape)
        np.testing.assert_array_equal(got, expected, err_msg=stem)
    assert max(int(m.max()) for m in result.label_maps.values()) >= 2, "a real segmentation"


def test_run_writes_byte_identical_files(run_outputs, stems):
    by_cli, result = run_outputs
    ours = Path(result.out)
    names = OUTPUTS + [f"{d}/{s}.png" for d in ("masks", "overlays") for s in stems]
    for name in names:
        assert (ours / name).read_bytes() == (by_cli / name).read_bytes(), name


def test_run_object_ids_equal_the_plys_column(run_outputs, scene):
    by_cli, result = run_outputs
    names, rows = read_ply_columns(by_cli / "gaussians.ply")
    _, inputs = read_ply_columns(scene / "gaussians.ply")
    ids = result.object_ids
    assert ids.dtype == np.int32 and ids.shape == (len(inputs),)
    np.testing.assert_array_equal(ids, rows["object_id"])
    assert (ids >= 1).sum() > len(ids) // 2 and ids.min() >= -1


def test_run_objects_equal_splatseg_objects_json(run_outputs):
    by_cli, result = run_outputs
    table = json.loads(cli("objects", by_cli / "gaussians.ply", "--json"))
    assert result.objects == table["objects"]
    assert {o["id"] for o in result.objects} >= {int(i) for i in np.unique(result.object_ids) if i > 0}


def test_run_report_and_summary_are_the_files(run_outputs):
    by_cli, result = run_outputs
    assert result.report == (by_cli / "report.md").read_text()
    assert result.summary == json.loads((by_cli / "metrics.json").read_text())


def test_run_without_out_leaves_no_folder_and_gives_the_same_maps(run_outputs, scene, caplog):
    _, with_out = run_outputs
    before = set(Path(tempfile.gettempdir()).glob("splatseg-run-*"))
    with caplog.at_level(logging.INFO, logger="splatseg"):
        result = splatseg.run(scene, masks=scene / "sam", features=scene / "features")
    assert result.out is None
    assert set(Path(tempfile.gettempdir()).glob("splatseg-run-*")) == before
    for stem, expected in with_out.label_maps.items():
        np.testing.assert_array_equal(result.label_maps[stem], expected)
    np.testing.assert_array_equal(result.object_ids, with_out.object_ids)
    # Progress through logging: every stage's start and end.
    messages = [r.getMessage() for r in caplog.records if r.name == "splatseg"]
    for stage in ("load inputs", "match", "outputs and eval"):
        assert any(m == f"stage {stage}: started" for m in messages), messages
        assert any(m.startswith(f"stage {stage}: ") and m.endswith("MB") for m in messages), messages


def test_run_config_dict_is_the_toml_table(workdir, scene):
    toml = workdir / "config.toml"
    toml.write_text("[merge]\ntau_merge = 0.95\n[final_maps]\nkind = \"rendered\"\n")
    by_file = splatseg.run(scene, masks=scene / "sam", config=toml)
    by_dict = splatseg.run(scene, masks=scene / "sam", config={"merge": {"tau_merge": 0.95}, "final_maps": {"kind": "rendered"}})
    without_out = lambda summary: {k: v for k, v in summary.items() if k != "out"}  # noqa: E731 (temporary folders)
    assert without_out(by_file.summary) == without_out(by_dict.summary)
    for stem, expected in by_file.label_maps.items():
        np.testing.assert_array_equal(by_dict.label_maps[stem], expected)


def test_config_errors_carry_the_command_lines_messages(scene):
    with pytest.raises(ValueError, match=r"\[objects\] tau_seam"):
        splatseg.run(scene, masks=scene / "sam", config={"lift": {"tau_seam": 0.8}})
    with pytest.raises(ValueError, match="out of range"):
        splatseg.run(scene, masks=scene / "sam", config={"merge": {"tau_merge": 2.0}})
    with pytest.raises(FileNotFoundError, match="no_such.toml"):
        splatseg.run(scene, masks=scene / "sam", config=scene / "no_such.toml")


def test_run_missing_inputs_raise_file_not_found(workdir, scene):
    with pytest.raises(FileNotFoundError, match="nowhere"):
        splatseg.run(workdir / "nowhere", masks=scene / "sam")
    with pytest.raises(FileNotFoundError, match="missing.ply"):
        splatseg.run(scene, masks=scene / "sam", gaussians=workdir / "missing.ply")


def test_run_refuses_to_overwrite_an_input(scene):
    before = (scene / "gaussians.ply").read_bytes()
    with pytest.raises(ValueError, match="masks"):
        splatseg.run(scene, masks=scene / "sam", out=scene / "sam")
    assert (scene / "gaussians.ply").read_bytes() == before


def test_run_releases_the_gil_while_it_works(scene):
    """Another Python thread keeps running during a call (it would stand still if the GIL were held)."""
    import threading
    import time

    def spin(seconds: float) -> float:
        """Loop iterations per second of this thread alone."""
        count, end = 0, time.perf_counter() + seconds
        while time.perf_counter() < end:
            count += 1
        return count / seconds

    alone = spin(0.2)
    done = threading.Event()
    failure: list = []

    def call():
        # Calls until at least 0.3 s have passed: one call on this small scene can take 0.04 s,
        # too short a window to count the other thread's loops in.
        try:
            end = time.perf_counter() + 0.3
            while True:
                splatseg.run(scene, masks=scene / "sam", config={"merge": {"tau_merge": 0.9}})
                if time.perf_counter() >= end:
                    break
        except Exception as e:  # noqa: BLE001 (reported below)
            failure.append(e)
        finally:
            done.set()

    worker = threading.Thread(target=call)
    started = time.perf_counter()
    worker.start()
    count = 0
    while not done.is_set():
        time.perf_counter()
        count += 1
    seconds = time.perf_counter() - started
    worker.join()
    assert not failure, failure
    rate = count / seconds
    assert rate > 0.05 * alone, f"this thread ran {rate:.0f} loops/s during the call, {alone:.0f} alone"
