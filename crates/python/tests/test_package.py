"""The installed package: NumPy is its only requirement, and the stub covers the API."""

from __future__ import annotations

import ast
from importlib import metadata
from pathlib import Path

import splatseg


def test_numpy_is_the_only_requirement():
    requires = metadata.requires("splatseg") or []
    assert [r.split(">")[0].split("=")[0].strip() for r in requires] == ["numpy"], requires


def test_the_stub_declares_every_public_function_with_the_same_parameters():
    stub = Path(splatseg.__file__).with_name("__init__.pyi")
    assert stub.is_file(), "the .pyi stub is installed"
    tree = ast.parse(stub.read_text())
    declared = {f.name: f for f in tree.body if isinstance(f, ast.FunctionDef)}
    import inspect

    for name in splatseg.__all__:
        if name == "RunResult":
            continue
        assert name in declared, name
        stub_args = [a.arg for a in declared[name].args.args + declared[name].args.kwonlyargs]
        assert stub_args == list(inspect.signature(getattr(splatseg, name)).parameters), name
    assert (Path(splatseg.__file__).parent / "py.typed").is_file()
