"""Shared fixtures: a synthetic scene written by `splatseg synth`, and the command line's outputs on it.

The binary is `SPLATSEG_BIN`, else `target/release/splatseg` of the workspace (`cargo build
--release`); without it the tests fail (they are the comparison with the command line).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

WORKSPACE = Path(__file__).resolve().parents[3]
VIEWS, SIZE = 3, "96x72"


def binary() -> Path:
    path = Path(os.environ.get("SPLATSEG_BIN", WORKSPACE / "target" / "release" / "splatseg"))
    if not path.is_file():
        pytest.fail(
            f"no splatseg binary at {path}: build it with `cargo build --release` or set SPLATSEG_BIN "
            "(these tests compare the package with the command line)",
            pytrace=False,
        )
    return path


def cli(*args: object) -> str:
    """Runs the command line; fails the test with its stderr when it fails."""
    done = subprocess.run([str(binary()), "-q", *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, f"splatseg {' '.join(map(str, args))} failed:\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="session")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("splatseg")


@pytest.fixture(scope="session")
def scene(workdir) -> Path:
    """A small synthetic capture: images/, sparse/, sam/, features/, depth/, gt/, gaussians.ply."""
    path = workdir / "scene"
    cli("synth", "--out", path, "--views", VIEWS, "--size", SIZE, "--seed", 3)
    return path


@pytest.fixture(scope="session")
def stems(scene) -> list:
    return sorted(p.stem for p in (scene / "sam").glob("*.json"))


@pytest.fixture(scope="session")
def run_outputs(workdir, scene):
    """`splatseg run` and `splatseg.run` on the scene with features, each into the same path
    (the outputs name their folder); returns (the command line's folder, the package's result)."""
    import splatseg

    same = workdir / "run_out"
    cli("run", scene, "--masks", scene / "sam", "--features", scene / "features", "--out", same)
    by_cli = workdir / "run_cli"
    same.rename(by_cli)
    result = splatseg.run(scene, masks=scene / "sam", features=scene / "features", out=same)
    return by_cli, result


@pytest.fixture(scope="session")
def scene_without_ply(workdir, scene) -> Path:
    """The scene without its gaussians.ply, so `splatseg merge` takes the given depth alone."""
    path = workdir / "scene_no_ply"
    shutil.copytree(scene, path, ignore=shutil.ignore_patterns("gaussians.ply"))
    return path
