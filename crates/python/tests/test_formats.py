"""read_ply on SPZ, .splat, .ksplat and compressed PLY (issue 61): the reference library's files, our writers'
files, and the positions an independent reading of SPZ and .splat bytes (gzip + NumPy, here) finds."""

from __future__ import annotations

import gzip
import struct
from pathlib import Path

import numpy as np
import pytest

import splatseg
from conftest import WORKSPACE

FIXTURES = WORKSPACE / "crates" / "scene" / "tests" / "fixtures"
COMPACT = [".spz", ".splat", ".ksplat", ".compressed.ply"]
SH_C0 = 0.28209479177387814


def spz_means(path: Path) -> np.ndarray:
    """The centres of an SPZ (versions 2-3) read from its bytes: 24-bit fixed point, turned 180 degrees
    about x into the PLY's frame (y and z negated)."""
    raw = gzip.decompress(Path(path).read_bytes())
    magic, version, n, _, fractional_bits, _, _ = struct.unpack("<4sIIBBBB", raw[:16])
    assert magic == b"NGSP" and version in (2, 3), (magic, version)
    b = np.frombuffer(raw, dtype=np.uint8, count=9 * n, offset=16).reshape(n, 3, 3).astype(np.int32)
    fixed = b[..., 0] | (b[..., 1] << 8) | (b[..., 2] << 16)
    fixed = np.where(fixed & 0x800000, fixed - (1 << 24), fixed)
    return (fixed / float(1 << fractional_bits) * np.array([1.0, -1.0, -1.0])).astype(np.float32)


def splat_means(path: Path) -> np.ndarray:
    """The centres of an antimatter15 .splat: 32 bytes a Gaussian, the first 12 three f32."""
    rows = np.frombuffer(Path(path).read_bytes(), dtype=np.uint8).reshape(-1, 32)
    return rows[:, :12].copy().view("<f4").reshape(-1, 3)


def tolerance(ext: str, means: np.ndarray) -> np.ndarray:
    """Half a quantisation step of a position per axis (compressed PLY: of a chunk's range, at most the extent)."""
    if ext == ".spz":
        return np.full(3, 0.5 / 4096 + 1e-6)
    if ext == ".compressed.ply":
        return 0.5 * (means.max(0) - means.min(0)) / 1023 + 1e-5
    return np.full(3, 1e-6)


def test_read_ply_reads_the_reference_spz_and_compressed_ply_as_their_source():
    source = splatseg.read_ply(FIXTURES / "splats_source.ply")
    spz = splatseg.read_ply(FIXTURES / "splats_reference.spz")
    np.testing.assert_array_equal(spz["means"], spz_means(FIXTURES / "splats_reference.spz"))
    assert np.abs(spz["means"] - source["means"]).max() <= tolerance(".spz", source["means"]).max()
    opacity = lambda g: 1 / (1 + np.exp(-g["raw_opacities"]))  # noqa: E731
    assert np.abs(opacity(spz) - opacity(source)).max() <= 0.5 / 255 + 1e-6
    assert spz["sh"].shape == source["sh"].shape and "object_ids" not in spz
    compressed = splatseg.read_ply(FIXTURES / "splats_reference.compressed.ply")
    # splat-transform sorts the Gaussians along a Morton curve: each matched to its nearest source.
    distance = np.linalg.norm(compressed["means"][:, None, :] - source["means"][None, :, :], axis=2)
    nearest = distance.argmin(1)
    assert sorted(nearest) == list(range(len(source["means"])))
    off = np.abs(compressed["means"] - source["means"][nearest])
    assert (off <= tolerance(".compressed.ply", source["means"])).all(), off.max(0)


@pytest.mark.parametrize("ext", COMPACT)
def test_read_ply_reads_what_write_ply_wrote_in_each_format(scene, tmp_path, ext):
    source = splatseg.read_ply(scene / "gaussians.ply")
    path = tmp_path / f"scene{ext}"
    splatseg.write_ply(path, source, keep_extras=False)
    g = splatseg.read_ply(path)
    assert len(g["means"]) == len(source["means"])
    off = np.abs(g["means"] - source["means"])
    assert (off <= tolerance(ext, source["means"])).all(), (ext, off.max(0))
    if ext == ".spz":
        np.testing.assert_array_equal(g["means"], spz_means(path))
    if ext == ".splat":
        np.testing.assert_array_equal(g["means"], splat_means(path))
    # Colour to a byte or better in every format.
    colour = lambda g: np.clip(SH_C0 * g["sh"][:, 0] + 0.5, 0, 1) * 255  # noqa: E731
    assert np.abs(colour(g) - colour(source)).max() <= 2.0, ext
    assert "object_ids" not in g and "features" not in g


@pytest.mark.parametrize("ext", COMPACT)
def test_a_compact_file_has_no_objects_to_extract(run_outputs, tmp_path, ext):
    by_cli, result = run_outputs
    labelled = splatseg.read_ply(by_cli / "gaussians.ply")
    with pytest.raises(ValueError, match="holds no"):
        splatseg.write_ply(tmp_path / f"kept{ext}", labelled)
    assert not (tmp_path / f"kept{ext}").exists()
    splatseg.write_ply(tmp_path / f"scene{ext}", labelled, keep_extras=False)
    g = splatseg.read_ply(tmp_path / f"scene{ext}")
    with pytest.raises(ValueError, match="object_id"):
        splatseg.extract(g, [result.objects[0]["id"]])
