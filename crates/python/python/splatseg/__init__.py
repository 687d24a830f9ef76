"""splatseg from Python: view-consistent objects for 3D Gaussian Splatting scenes, on NumPy arrays.

The functions call the same Rust libraries as the ``splatseg`` command line (no subprocess):

- :func:`run` — the whole pipeline of ``splatseg run`` on a scene folder; returns a :class:`RunResult`
  with the final label maps, every Gaussian's object id, the object table and the report.
- :func:`merge_view` — one view's SAM masks merged with its cues (``splatseg merge``'s per-view step),
  from arrays: SAM's ``generate()`` output, the image, DINOv2 features, a depth map.
- :func:`read_ply` / :func:`write_ply` — 3DGS PLYs as dicts of arrays in the INRIA layout.
- :func:`extract` / :func:`remove` — the Gaussians of some objects, or all but them.
- :func:`apply_edits` — a run's corrections (``OUT/edits.json``: merge, split, reassign, rename)
  applied to its outputs, as ``splatseg apply OUT``; :func:`edit_inputs` gives the run's identity
  that the file must carry.

Arrays: inputs in C order with the expected dtype are read in place (others are converted
once, never modified); every returned array owns its buffer. Calls release the GIL while they
work. Progress and warnings go to the ``logging`` logger ``"splatseg"`` (each pipeline stage's
start and end at INFO). Errors raise ``FileNotFoundError`` (a missing input), ``OSError`` (other
file-system failures) or ``ValueError`` (bad input or settings), with the command line's
messages.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native

__all__ = [
    "RunResult",
    "run",
    "merge_view",
    "read_ply",
    "write_ply",
    "extract",
    "remove",
    "apply_edits",
    "edit_inputs",
]

PathLike = Union[str, "os.PathLike[str]"]
Config = Union[PathLike, Mapping[str, Any], None]


@dataclass
class RunResult:
    """What :func:`run` produced.

    Attributes:
        label_maps: image stem -> ``uint16[H, W]`` final label map (global object id, 0 = none),
            the same ids in every view; equal to ``OUT/masks/<stem>.png``.
        object_ids: ``int32[N]`` object id of every row of the input PLY (-1 = unreliable), as
            ``OUT/gaussians.ply``'s ``object_id``; ``None`` when the run had no Gaussians.
        objects: one dict per object, as ``splatseg objects OUT/gaussians.ply
            --json`` lists them: ``id``, ``gaussian_count``, ``bbox_min`` and ``bbox_max``
            (``[x, y, z]`` of the centres), ``colour`` (``[r, g, b]``, the overlays' colour),
            ``views_seen`` (label maps showing it), and ``name`` for an object named by the
            edits (``OUT/objects.json``, which :func:`apply_edits` writes; absent otherwise).
        report: ``OUT/report.md``.
        summary: ``OUT/metrics.json`` (counts per stage, what matching and lifting decided).
        out: the output folder when one was given, else ``None`` (a temporary folder was used
            and removed).
        applied: what :func:`apply_edits` did: ``operations``, ``changed_gaussians``,
            ``objects``, ``names``, ``views`` (counts); ``None`` from :func:`run`.
    """

    label_maps: Dict[str, np.ndarray]
    object_ids: Optional[np.ndarray]
    objects: List[Dict[str, Any]]
    report: str
    summary: Dict[str, Any] = field(default_factory=dict)
    out: Optional[str] = None
    applied: Optional[Dict[str, int]] = None


def _config(config: Config):
    """(path, json text) for the native layer: a TOML path, a dict of tables, or neither."""
    if config is None:
        return None, None
    if isinstance(config, Mapping):
        return None, json.dumps(config)
    if isinstance(config, (str, os.PathLike)):
        return os.fspath(config), None
    raise ValueError(
        f"config is a {type(config).__name__}: expected a path to a TOML file or a dict with its tables"
    )


def _path(value: Optional[PathLike], name: str) -> Optional[str]:
    if value is None:
        return None
    if not isinstance(value, (str, os.PathLike)):
        raise ValueError(f"{name} is a {type(value).__name__}: expected a path")
    return os.fspath(value)


def run(
    scene: PathLike,
    *,
    masks: PathLike,
    gaussians: Optional[PathLike] = None,
    features: Optional[PathLike] = None,
    depth: Optional[PathLike] = None,
    depth_kind: str = "inverse",
    out: Optional[PathLike] = None,
    config: Config = None,
) -> RunResult:
    """Run the whole pipeline (``splatseg run``) on a scene folder.

    Args:
        scene: scene folder: COLMAP (``sparse/0`` + ``images/``), NeRF/Blender
            ``transforms_*.json`` or instant-ngp/nerfstudio ``transforms.json``.
        masks: folder of SAM masks, one per image stem (``<stem>.json`` as SAM's ``amg.py``
            writes, or ``<stem>/metadata.csv`` + PNGs).
        gaussians: 3DGS PLY (INRIA layout, e.g. a gsplat or nerfstudio export); default
            ``SCENE/gaussians.ply`` when present.
        features: folder of ``<stem>.npy`` dense features ``float32[h, w, C]`` on any grid (e.g.
            DINOv2 patch tokens); without it, model-free colour/texture descriptors.
        depth: folder of ``<stem>.npy`` depth maps ``float32[H, W]``; without it, depth is
            rendered from the Gaussians.
        depth_kind: what ``depth`` holds: ``"inverse"`` (relative inverse depth, e.g. Depth
            Anything) or ``"metric"`` (camera z).
        out: output folder (``masks/``, ``overlays/``, ``gaussians.ply``, ``report.md``,
            ``metrics.json``, ``cache/``), byte-identical to ``splatseg run --out``; a rerun
            resumes from its cache. ``None``: a temporary folder, removed before returning.
        config: the settings: a path to a TOML file (``splatseg config``) or a dict with its
            tables, e.g. ``{"merge": {"tau_merge": 0.8}}``.

    Returns:
        A :class:`RunResult`. When ``out`` holds outputs of this run already (its inputs and
        settings unchanged), nothing is recomputed and they are read as they are: after
        :func:`apply_edits`, the edited ids, maps and names.

    Raises:
        FileNotFoundError: a missing input (the message names it).
        ValueError: bad input or settings, or ``out`` would overwrite an input.
    """
    config_path, config_json = _config(config)
    native = _native.run(
        _path(scene, "scene"),
        _path(masks, "masks"),
        _path(gaussians, "gaussians"),
        _path(features, "features"),
        _path(depth, "depth"),
        depth_kind,
        _path(out, "out"),
        config_path,
        config_json,
    )
    return _native_result(native, _path(out, "out"))


def _float32(value: Any, name: str) -> Optional[np.ndarray]:
    """``value`` as float32 (read in place when it already is; converted from other floats)."""
    if value is None:
        return None
    array = np.asarray(value)
    if array.dtype == np.float32:
        return array
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(f"{name} has dtype {array.dtype}: expected float32 (or another float dtype)")
    return array.astype(np.float32)


def merge_view(
    masks: Union[np.ndarray, Sequence[Mapping[str, Any]]],
    *,
    image: np.ndarray,
    features: Optional[np.ndarray] = None,
    depth: Optional[np.ndarray] = None,
    depth_kind: str = "inverse",
    intrinsics: Optional[Sequence[float]] = None,
    config: Config = None,
) -> np.ndarray:
    """Merge one view's over-segmented SAM masks into objects (``splatseg merge``'s per-view step).

    Args:
        masks: ``bool[K, H, W]``, or the list of dicts SAM's ``generate()`` returns, each with
            ``segmentation`` as ``bool[H, W]`` or COCO RLE (``{"size": [H, W], "counts": str |
            list[int]}``) and optionally ``predicted_iou`` and ``stability_score`` (1 when
            absent, as in a mask file without them).
        image: ``uint8[H, W, 3]`` RGB.
        features: ``float32[h, w, C]`` dense features on any grid (e.g. DINOv2 patch tokens,
            channels last); ``None``: model-free colour/texture descriptors.
        depth: ``float32[h, w]`` depth (resampled bilinearly to ``H x W`` when another size).
            Required: ``merge_view`` has no Gaussians to render depth from.
        depth_kind: ``"inverse"`` (relative inverse depth, larger = nearer, e.g. Depth Anything)
            or ``"metric"`` (camera z, 0 = no surface).
        intrinsics: ``(fx, fy, cx, cy)`` in pixels of the ``H x W`` image; with metric depth they
            turn on the concave-crease gate, as ``splatseg merge`` does with the scene's camera.
        config: a path to the pipeline's TOML or a dict with its tables; the ``[merge]`` table
            applies.

    Returns:
        ``uint32[H, W]`` merged regions: 0 = no mask, regions numbered ``1..n``; equal to
        ``splatseg merge``'s ``OUT/masks/<stem>.png`` on the same inputs.

    Raises:
        ValueError: a wrong dtype or shape (the message names the argument and what was
            expected), no depth, or bad settings.
    """
    config_path, config_json = _config(config)
    if intrinsics is not None:
        intrinsics = tuple(float(v) for v in intrinsics)
        if len(intrinsics) != 4:
            raise ValueError(f"intrinsics has {len(intrinsics)} values: expected (fx, fy, cx, cy)")
    if not isinstance(masks, (list, tuple)):
        masks = np.asarray(masks)
    else:
        masks = list(masks)
    return _native.merge_view(
        masks,
        np.asarray(image),
        _float32(features, "features"),
        _float32(depth, "depth"),
        depth_kind,
        intrinsics,
        config_path,
        config_json,
    )


def read_ply(path: PathLike, *, strict: bool = False) -> Dict[str, Any]:
    """Read a 3DGS PLY (binary or ASCII, SH degree 0-3) as a dict of arrays; an SPZ (versions 2-3),
    a ``.splat``, a ``.ksplat`` or a compressed PLY is read too (chosen by content; quantised, without ids or extras).

    Keys: ``means`` ``float32[N, 3]``, ``log_scales`` ``float32[N, 3]``, ``rotations_wxyz``
    ``float32[N, 4]`` (unnormalised), ``raw_opacities`` ``float32[N]`` (before the sigmoid),
    ``sh`` ``float32[N, K, 3]`` (``K = (degree + 1)**2``; ``sh[:, 0]`` is ``f_dc``), and when the
    file has them ``normals`` ``float32[N, 3]``, ``object_ids`` ``int32[N]`` (-1 = none),
    ``features`` ``float32[N, D]``; ``extra`` maps every other property's name to its ``[N]``
    array (dtype of its PLY type).

    Gaussians with a non-finite value are left out with one warning (``logging``), as the
    command line's ``extract`` and ``remove`` do; ``strict=True`` refuses such a file.
    """
    return _native.read_ply(_path(path, "path"), bool(strict))


def write_ply(path: PathLike, gaussians: Mapping[str, Any], *, keep_extras: bool = True) -> None:
    """Write a dict of arrays (the layout of :func:`read_ply`) as a binary 3DGS PLY, atomically.

    ``keep_extras=False`` leaves out ``object_ids``, ``features`` and ``extra`` (exactly the INRIA
    properties, which every viewer opens), as ``splatseg extract`` / ``remove`` write by default.
    A path ending in ``.spz``, ``.splat``, ``.ksplat`` or ``.compressed.ply`` writes that format, which holds no ids, features or
    extras: with any of them in ``gaussians``, pass ``keep_extras=False``.
    """
    _native.write_ply(_path(path, "path"), _gaussians(gaussians), bool(keep_extras))


def _gaussians(gaussians: Mapping[str, Any]) -> dict:
    if not isinstance(gaussians, Mapping):
        raise ValueError(f"gaussians is a {type(gaussians).__name__}: expected the dict of splatseg.read_ply")
    return dict(gaussians)


def _ids(ids: Union[int, Sequence[int], np.ndarray]) -> List[int]:
    if isinstance(ids, (int, np.integer)):
        return [int(ids)]
    return [int(i) for i in np.asarray(ids).reshape(-1)]


def extract(gaussians: Mapping[str, Any], ids: Union[int, Sequence[int], np.ndarray]) -> Dict[str, Any]:
    """The Gaussians of objects ``ids`` (by ``object_ids``), in their order, every array kept.

    Raises ``ValueError`` when there are no ``object_ids``, no ids are given, or an id is carried
    by no Gaussian (the message lists the ids present), as ``splatseg extract``.
    """
    return _native.select(_gaussians(gaussians), _ids(ids), True)


def remove(gaussians: Mapping[str, Any], ids: Union[int, Sequence[int], np.ndarray]) -> Dict[str, Any]:
    """Every Gaussian but those of objects ``ids``, in their order (see :func:`extract`)."""
    return _native.select(_gaussians(gaussians), _ids(ids), False)


def _native_result(native: Mapping[str, Any], out: Optional[str]) -> RunResult:
    return RunResult(
        label_maps=native["label_maps"],
        object_ids=native["object_ids"],
        objects=json.loads(native["objects_json"]),
        report=native["report"],
        summary=json.loads(native["summary_json"]),
        out=out,
        applied=json.loads(native["applied_json"]) if "applied_json" in native else None,
    )


def apply_edits(out: PathLike, *, strict: bool = False) -> RunResult:
    """Apply a run's corrections, ``OUT/edits.json``, to its outputs (``splatseg apply OUT``).

    The operations (``merge``, ``split_box``, ``split_lasso``, ``assign``, ``rename``; the format
    is in the README, "Fixing the result") start from the run's own result, so the same edits
    give the same bytes however often they are applied. Rewritten: ``gaussians.ply``'s
    ``object_id``, every view's label map and overlay (rendered again through the edited
    Gaussians), ``objects.json`` (the objects with their names) and ``report.md``; written as
    ``splatseg run`` writes, staged then moved in. ``run --clip``'s object embeddings
    (``OUT/objects/``) describe the run's objects and are removed: ``splatseg apply`` embeds
    the edited objects again, this function does not (it has no CLIP model).

    Args:
        out: a finished run's output folder (``splatseg run --out`` or :func:`run`'s ``out``),
            holding ``edits.json``.
        strict: refuse a ``gaussians.ply`` with non-finite values instead of skipping them.

    Returns:
        A :class:`RunResult` read from the edited folder: ``object_ids`` ``int32[N]``, the
        label maps ``uint16[H, W]``, ``objects`` with a ``name`` for each named object, and
        ``applied`` (how many operations, changed Gaussians, objects, names and views).

    Raises:
        FileNotFoundError: no ``edits.json`` in ``out`` (the message names the path).
        ValueError: edits that cannot be applied, with the command line's message naming
            ``edits.json`` (and the operation's index when one selects something absent): a
            malformed or later-version file, edits made on another run or PLY, an unknown id,
            Gaussian rows out of range; or ``out`` holds no finished run. Nothing is changed
            then.

    Examples:
        >>> inputs = splatseg.edit_inputs("result/")
        >>> edits = {"version": 1, "inputs": inputs, "operations": [
        ...     {"op": "merge", "ids": [3, 7]}, {"op": "rename", "id": 3, "name": "chair"}]}
        >>> Path("result/edits.json").write_text(json.dumps(edits))
        >>> result = splatseg.apply_edits("result/")
        >>> [o["id"] for o in result.objects if o.get("name") == "chair"]
        [3]
    """
    path = _path(out, "out")
    return _native_result(_native.apply_edits(path, bool(strict)), path)


def edit_inputs(out: PathLike) -> Dict[str, Any]:
    """The identity of the run in ``out`` that its ``edits.json`` must name as ``"inputs"``.

    Returns:
        ``{"gaussians": int, "ply_digest": str, "run": str}``: the rows of the run's
        ``gaussians.ply``, the digest of their centres and the run's key
        (``OUT/cache/run.json``). Edits naming other inputs are refused by :func:`apply_edits`.

    Raises:
        ValueError: ``out`` holds no finished run.
        FileNotFoundError: its ``gaussians.ply`` is missing.
    """
    return json.loads(_native.edit_inputs(_path(out, "out")))
