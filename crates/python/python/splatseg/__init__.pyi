"""Types of the splatseg package (shapes and dtypes in the docstrings of __init__.py)."""

import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, TypedDict, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike[str]]
Config = Union[PathLike, Mapping[str, Any], None]

class SamMask(TypedDict, total=False):
    """One entry of SAM's generate() output."""

    segmentation: Union[npt.NDArray[np.bool_], Dict[str, Any]]  # bool[H, W] or COCO RLE {"size": [H, W], "counts": str | list[int]}
    predicted_iou: float
    stability_score: float

class _ObjectRowRequired(TypedDict):
    """The keys every row of RunResult.objects has."""

    id: int
    gaussian_count: int
    bbox_min: List[float]  # [3] x, y, z
    bbox_max: List[float]  # [3] x, y, z
    colour: List[int]  # [3] r, g, b
    views_seen: Optional[int]

class ObjectRow(_ObjectRowRequired, total=False):
    """One row of RunResult.objects (as `splatseg objects --json`)."""

    name: str  # only for an object named by the edits (apply_edits)

class Gaussians(TypedDict, total=False):
    """A 3DGS PLY in the INRIA layout (read_ply / write_ply)."""

    means: npt.NDArray[np.float32]  # float32[N, 3]
    log_scales: npt.NDArray[np.float32]  # float32[N, 3]
    rotations_wxyz: npt.NDArray[np.float32]  # float32[N, 4]
    raw_opacities: npt.NDArray[np.float32]  # float32[N]
    sh: npt.NDArray[np.float32]  # float32[N, K, 3], K = (degree + 1) ** 2
    normals: npt.NDArray[np.float32]  # float32[N, 3]
    object_ids: npt.NDArray[np.int32]  # int32[N], -1 = none
    features: npt.NDArray[np.float32]  # float32[N, D]
    extra: Dict[str, np.ndarray]  # name -> [N] array of the property's PLY type

@dataclass
class RunResult:
    label_maps: Dict[str, npt.NDArray[np.uint16]]  # stem -> uint16[H, W], 0 = none
    object_ids: Optional[npt.NDArray[np.int32]]  # int32[N], -1 = unreliable
    objects: List[ObjectRow]
    report: str
    summary: Dict[str, Any] = ...
    out: Optional[str] = ...
    applied: Optional[Dict[str, int]] = ...  # apply_edits: operations, changed_gaussians, objects, names, views

class EditInputs(TypedDict):
    """edits.json's "inputs": the run the edits were made on."""

    gaussians: int
    ply_digest: str
    run: str

def run(
    scene: PathLike,
    *,
    masks: PathLike,
    gaussians: Optional[PathLike] = None,
    features: Optional[PathLike] = None,  # folder of <stem>.npy float32[h, w, C]
    depth: Optional[PathLike] = None,  # folder of <stem>.npy float32[H, W]
    depth_kind: str = "inverse",  # "inverse" | "metric"
    out: Optional[PathLike] = None,
    config: Config = None,
) -> RunResult: ...
def merge_view(
    masks: Union[npt.NDArray[np.bool_], Sequence[SamMask]],  # bool[K, H, W] or SAM generate() dicts
    *,
    image: npt.NDArray[np.uint8],  # uint8[H, W, 3]
    features: Optional[npt.NDArray[np.floating[Any]]] = None,  # float32[h, w, C], any grid
    depth: Optional[npt.NDArray[np.floating[Any]]] = None,  # float32[h, w], resampled to [H, W]
    depth_kind: str = "inverse",  # "inverse" | "metric"
    intrinsics: Optional[Sequence[float]] = None,  # (fx, fy, cx, cy) px
    config: Config = None,
) -> npt.NDArray[np.uint32]: ...  # uint32[H, W], 0 = none, regions 1..n
def read_ply(path: PathLike, *, strict: bool = False) -> Gaussians: ...
def write_ply(path: PathLike, gaussians: Gaussians, *, keep_extras: bool = True) -> None: ...
def extract(gaussians: Gaussians, ids: Union[int, Sequence[int], npt.NDArray[np.integer[Any]]]) -> Gaussians: ...
def remove(gaussians: Gaussians, ids: Union[int, Sequence[int], npt.NDArray[np.integer[Any]]]) -> Gaussians: ...
def apply_edits(out: PathLike, *, strict: bool = False) -> RunResult: ...
def edit_inputs(out: PathLike) -> EditInputs: ...
