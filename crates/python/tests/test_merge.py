"""splatseg.merge_view against `splatseg merge` on the same inputs."""

from __future__ import annotations

import json

import numpy as np
import pytest

import splatseg
from conftest import cli
from helpers import decode_rle, read_png


def view_inputs(scene, stem):
    masks = json.loads((scene / "sam" / f"{stem}.json").read_text())
    image = read_png(next((scene / "images").glob(f"{stem}.*")))
    features = np.load(scene / "features" / f"{stem}.npy")
    depth = np.load(scene / "depth" / f"{stem}.npy")
    return masks, image[:, :, :3].copy(), features, depth


@pytest.fixture(scope="module")
def merged_by_cli(workdir, scene_without_ply):
    """`splatseg merge` with features and depth (inverse), and without features."""
    s = scene_without_ply
    with_features, without = workdir / "merge_feat", workdir / "merge_plain"
    cli("merge", s, "--masks", s / "sam", "--features", s / "features", "--depth", s / "depth", "--out", with_features)
    cli("merge", s, "--masks", s / "sam", "--depth", s / "depth", "--out", without)
    return with_features, without


def test_merge_view_on_sam_dicts_equals_splatseg_merge(scene, stems, merged_by_cli):
    with_features, _ = merged_by_cli
    for stem in stems:
        masks, image, features, depth = view_inputs(scene, stem)
        got = splatseg.merge_view(masks, image=image, features=features, depth=depth)
        expected = read_png(with_features / "masks" / f"{stem}.png")
        assert got.dtype == np.uint32 and got.shape == image.shape[:2]
        np.testing.assert_array_equal(got, expected, err_msg=stem)
        assert 1 < got.max() < len(masks), "the merge joined some masks and kept several regions"


def test_merge_view_on_a_bool_stack_equals_splatseg_merge(scene, stems, merged_by_cli):
    with_features, _ = merged_by_cli
    stem = stems[0]
    masks, image, features, depth = view_inputs(scene, stem)
    stack = np.stack([decode_rle(m["segmentation"]) for m in masks])
    for m in masks:  # a bool stack has no quality fields: 1, as a mask file without them
        m.pop("predicted_iou", None), m.pop("stability_score", None)
    got = splatseg.merge_view(stack, image=image, features=features, depth=depth)
    np.testing.assert_array_equal(got, read_png(with_features / "masks" / f"{stem}.png"))
    as_arrays = [{"segmentation": s} for s in stack]
    np.testing.assert_array_equal(splatseg.merge_view(as_arrays, image=image, features=features, depth=depth), got)


def test_merge_view_without_features_equals_splatseg_merge(scene, stems, merged_by_cli):
    _, without = merged_by_cli
    for stem in stems:
        masks, image, _, depth = view_inputs(scene, stem)
        got = splatseg.merge_view(masks, image=image, depth=depth)
        np.testing.assert_array_equal(got, read_png(without / "masks" / f"{stem}.png"), err_msg=stem)


def test_merge_view_modifies_no_input_and_owns_its_output(scene, stems):
    masks, image, features, depth = view_inputs(scene, stems[0])
    copies = (json.dumps(masks), image.copy(), features.copy(), depth.copy())
    got = splatseg.merge_view(masks, image=image, features=features, depth=depth)
    assert json.dumps(masks) == copies[0]
    for before, after in zip(copies[1:], (image, features, depth)):
        np.testing.assert_array_equal(before, after)
    assert got.flags.c_contiguous and got.flags.writeable
    assert not any(np.shares_memory(got, a) for a in (image, features, depth))
    got[:] = 0  # ours to change


def test_merge_view_reads_any_layout_and_float_dtype_alike(scene, stems):
    masks, image, features, depth = view_inputs(scene, stems[0])
    expected = splatseg.merge_view(masks, image=image, features=features, depth=depth)
    fortran = np.asfortranarray(image)
    strided_features = np.repeat(features, 2, axis=1)[:, ::2]  # not C-contiguous
    np.testing.assert_array_equal(strided_features, features)
    got = splatseg.merge_view(masks, image=fortran, features=strided_features, depth=depth.astype(np.float64))
    np.testing.assert_array_equal(got, expected)


def test_merge_view_checks_dtypes_and_shapes(scene, stems):
    masks, image, features, depth = view_inputs(scene, stems[0])
    with pytest.raises(ValueError, match=r"image .*float.*uint8\[H, W, 3\]"):
        splatseg.merge_view(masks, image=image.astype(np.float32), depth=depth)
    with pytest.raises(ValueError, match=r"image has shape .*uint8\[H, W, 3\]"):
        splatseg.merge_view(masks, image=image[:, :, :2].copy(), depth=depth)
    h, w = image.shape[:2]
    with pytest.raises(ValueError, match=rf"masks has shape .*bool\[K, {h}, {w}\]"):
        splatseg.merge_view(np.zeros((2, h + 1, w), bool), image=image, depth=depth)
    with pytest.raises(ValueError, match=r"masks\[0\]\['segmentation'\]: size"):
        bad = [dict(masks[0], segmentation={"size": [h, w + 1], "counts": [h * (w + 1)]})]
        splatseg.merge_view(bad, image=image, depth=depth)
    with pytest.raises(ValueError, match="features has dtype int"):
        splatseg.merge_view(masks, image=image, features=features.astype(np.int32), depth=depth)
    with pytest.raises(ValueError, match="features: non-finite"):
        splatseg.merge_view(masks, image=image, features=np.full_like(features, np.nan), depth=depth)
    with pytest.raises(ValueError, match="no depth"):
        splatseg.merge_view(masks, image=image)
    with pytest.raises(ValueError, match="depth_kind `far`"):
        splatseg.merge_view(masks, image=image, depth=depth, depth_kind="far")


def test_merge_view_config_dict_and_file_agree(workdir, scene, stems):
    masks, image, features, depth = view_inputs(scene, stems[0])
    toml = workdir / "merge.toml"
    toml.write_text("[merge]\ntau_merge = 0.6\n")
    by_file = splatseg.merge_view(masks, image=image, depth=depth, config=toml)
    by_dict = splatseg.merge_view(masks, image=image, depth=depth, config={"merge": {"tau_merge": 0.6}})
    np.testing.assert_array_equal(by_file, by_dict)
    default = splatseg.merge_view(masks, image=image, depth=depth)
    assert by_dict.max() <= default.max(), "a lower threshold merges at least as much"
