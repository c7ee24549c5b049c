"""The package's layout: the compiled module reynoldsflow._native is
re-exported whole, and its stub declares everything it exports."""

import ast
import os
import re
from importlib.metadata import metadata
from pathlib import Path

import reynoldsflow as rf
from reynoldsflow import _native


def _public(names):
    return {n for n in names if not n.startswith("_")}


def test_every_compiled_name_is_reexported():
    assert _public(dir(_native)) == set(rf.__all__)
    for name in rf.__all__:
        assert getattr(rf, name) is getattr(_native, name), name
    assert rf.__version__ == _native.__version__
    assert rf.Stream.__module__ == "reynoldsflow"


def test_stub_declares_every_compiled_name():
    root = Path(os.environ["REYNOLDSFLOW_REPO"])
    pkg = root / "python" / "pkg" / "reynoldsflow"
    tree = ast.parse((pkg / "_native.pyi").read_text())
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            declared.add(node.target.id)
    assert _public(dir(_native)) <= declared
    assert (pkg / "py.typed").is_file()
    # The installed package carries its stub and marker too.
    installed = Path(rf.__file__).parent
    assert (installed / "_native.pyi").is_file() and (installed / "py.typed").is_file()


def test_the_distribution_is_reynoldsflow_rs_at_the_workspace_version():
    # Every artifact's one version: Cargo.toml's [workspace.package] version.
    cargo = (Path(os.environ["REYNOLDSFLOW_REPO"]) / "Cargo.toml").read_text()
    workspace = re.search(r"^\[workspace\.package\]\n(.*?)^\[", cargo, re.M | re.S).group(1)
    version = re.search(r'^version = "([^"]+)"', workspace, re.M).group(1)
    meta = metadata("reynoldsflow-rs")
    assert meta["Name"] == "reynoldsflow-rs"
    assert meta["Version"] == version == rf.__version__
