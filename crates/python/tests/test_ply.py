"""read_ply / write_ply / extract / remove against the PLY files and `splatseg extract` / `remove`."""

from __future__ import annotations

import numpy as np
import pytest

import splatseg
from conftest import cli
from helpers import read_ply_columns

DTYPES = {
    "means": (np.float32, 3),
    "log_scales": (np.float32, 3),
    "rotations_wxyz": (np.float32, 4),
    "raw_opacities": (np.float32, None),
}


def test_read_ply_gives_the_inria_columns_as_arrays(run_outputs):
    by_cli, _ = run_outputs
    path = by_cli / "gaussians.ply"
    names, rows = read_ply_columns(path)
    g = splatseg.read_ply(path)
    n = len(rows)
    for key, (dtype, width) in DTYPES.items():
        assert g[key].dtype == dtype and g[key].shape == ((n, width) if width else (n,)), key
    np.testing.assert_array_equal(g["means"], np.stack([rows["x"], rows["y"], rows["z"]], 1))
    np.testing.assert_array_equal(g["log_scales"][:, 2], rows["scale_2"])
    np.testing.assert_array_equal(g["rotations_wxyz"][:, 0], rows["rot_0"])
    np.testing.assert_array_equal(g["raw_opacities"], rows["opacity"])
    rest = sorted((n for n in names if n.startswith("f_rest_")), key=lambda n: int(n[7:]))
    k = len(rest) // 3 + 1
    assert g["sh"].shape == (n, k, 3) and g["sh"].dtype == np.float32
    for c in range(3):
        np.testing.assert_array_equal(g["sh"][:, 0, c], rows[f"f_dc_{c}"])
        for j in range(k - 1):  # f_rest is channel-major: f_rest_{c*(K-1)+j} is coefficient j+1 of channel c
            np.testing.assert_array_equal(g["sh"][:, j + 1, c], rows[f"f_rest_{c * (k - 1) + j}"])
    assert g["object_ids"].dtype == np.int32
    np.testing.assert_array_equal(g["object_ids"], rows["object_id"])
    assert all(a.flags.c_contiguous for a in (g["means"], g["sh"], g["object_ids"]))


def test_write_ply_round_trips_byte_for_byte(run_outputs, tmp_path):
    by_cli, _ = run_outputs
    for source in (by_cli / "gaussians.ply",):
        g = splatseg.read_ply(source)
        splatseg.write_ply(tmp_path / "again.ply", g)
        assert (tmp_path / "again.ply").read_bytes() == source.read_bytes()
        again = splatseg.read_ply(tmp_path / "again.ply")
        assert sorted(again) == sorted(g)
        for key in DTYPES:
            np.testing.assert_array_equal(again[key], g[key])


def test_extra_properties_are_kept_with_their_type(scene, tmp_path):
    g = splatseg.read_ply(scene / "gaussians.ply")
    n = len(g["means"])
    g["extra"] = {"confidence": np.linspace(0, 1, n).astype(np.float64), "group": (np.arange(n) % 7).astype(np.uint8)}
    splatseg.write_ply(tmp_path / "extra.ply", g)
    names, rows = read_ply_columns(tmp_path / "extra.ply")
    assert names[-2:] == ["confidence", "group"]
    back = splatseg.read_ply(tmp_path / "extra.ply")
    assert back["extra"]["group"].dtype == np.uint8 and back["extra"]["confidence"].dtype == np.float64
    np.testing.assert_array_equal(back["extra"]["group"], g["extra"]["group"])
    np.testing.assert_array_equal(back["extra"]["confidence"], g["extra"]["confidence"])


@pytest.mark.parametrize("command", ["extract", "remove"])
def test_extract_and_remove_write_what_the_command_line_writes(run_outputs, tmp_path, command):
    by_cli, result = run_outputs
    ply = by_cli / "gaussians.ply"
    ids = [o["id"] for o in result.objects[:2]]
    cli(command, ply, "--ids", ",".join(map(str, ids)), "--out", tmp_path / "cli.ply")
    g = splatseg.read_ply(ply)
    picked = getattr(splatseg, command)(g, ids)
    splatseg.write_ply(tmp_path / "py.ply", picked, keep_extras=False)
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    inside = np.isin(g["object_ids"], ids)
    assert len(picked["means"]) == (inside.sum() if command == "extract" else (~inside).sum())


def test_extract_and_remove_partition_and_leave_the_input_alone(run_outputs):
    by_cli, result = run_outputs
    g = splatseg.read_ply(by_cli / "gaussians.ply")
    before = {k: v.copy() for k, v in g.items() if isinstance(v, np.ndarray)}
    some = result.objects[0]["id"]
    a, b = splatseg.extract(g, some), splatseg.remove(g, [some])
    assert len(a["means"]) + len(b["means"]) == len(g["means"])
    assert set(np.unique(a["object_ids"])) == {some} and some not in b["object_ids"]
    for key, value in before.items():
        np.testing.assert_array_equal(g[key], value)


def test_edit_errors_are_value_errors_with_the_command_lines_message(run_outputs, scene):
    by_cli, _ = run_outputs
    g = splatseg.read_ply(by_cli / "gaussians.ply")
    with pytest.raises(ValueError, match=r"no Gaussian has object id 9999; ids present: "):
        splatseg.extract(g, [9999])
    with pytest.raises(ValueError, match="no object id given"):
        splatseg.remove(g, [])
    plain = splatseg.read_ply(scene / "gaussians.ply")
    with pytest.raises(ValueError, match="no `object_id` property"):
        splatseg.extract(plain, [1])


def test_ply_errors(tmp_path, scene):
    with pytest.raises(FileNotFoundError, match="absent.ply"):
        splatseg.read_ply(tmp_path / "absent.ply")
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nend_header\n")
    with pytest.raises(ValueError, match="bad.ply"):
        splatseg.read_ply(tmp_path / "bad.ply")
    g = splatseg.read_ply(scene / "gaussians.ply")
    with pytest.raises(ValueError, match=r"gaussians\['means'\] must have dtype float32"):
        splatseg.write_ply(tmp_path / "x.ply", dict(g, means=g["means"].astype(np.float64)))
    with pytest.raises(ValueError, match=r"gaussians\['log_scales'\] has shape"):
        splatseg.write_ply(tmp_path / "x.ply", dict(g, log_scales=g["log_scales"][:-1]))
    with pytest.raises(ValueError, match=r"gaussians has no 'sh'"):
        splatseg.write_ply(tmp_path / "x.ply", {k: v for k, v in g.items() if k != "sh"})
    assert not (tmp_path / "x.ply").exists(), "nothing half-written"
