"""The type stubs shipped with the package (python/tsubu/_core.pyi) describe the compiled module:
every public name of tsubu._core and of its classes is in the stub, and the stub names nothing
the module does not have. A stub that falls behind the bindings fails here."""

import ast
import inspect
import os
import subprocess
import sys

import pytest

import tsubu
from tsubu import _core

STUB = os.path.join(os.path.dirname(tsubu.__file__), "_core.pyi")


def _stub_names():
    with open(STUB) as f:
        tree = ast.parse(f.read())
    top, classes = set(), {}

    def names_in(body):
        out = set()
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                out.add(node.name)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                out.add(node.target.id)
            elif isinstance(node, ast.Assign):
                out.update(t.id for t in node.targets if isinstance(t, ast.Name))
        return out

    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            classes[node.name] = names_in(node.body)
    top = names_in(tree.body)
    return top, classes


def _public(obj):
    return {n for n in dir(obj) if not n.startswith("_")}


def test_stub_is_shipped_with_the_package():
    assert os.path.isfile(STUB)
    assert os.path.isfile(os.path.join(os.path.dirname(tsubu.__file__), "py.typed"))


def test_module_names_match_the_stub():
    top, _ = _stub_names()
    assert _public(_core) - top == set(), "names of tsubu._core missing from _core.pyi"
    assert top - _public(_core) - {"__all__"} == set(), "names in _core.pyi that tsubu._core lacks"


@pytest.mark.parametrize("name", ["Simulation", "Material", "PairParams", "InstabilityError"])
def test_class_members_match_the_stub(name):
    _, classes = _stub_names()
    cls = getattr(_core, name)
    assert inspect.isclass(cls)
    inherited = _public(RuntimeError) if issubclass(cls, BaseException) else set()
    members = _public(cls) - inherited
    assert members - classes[name] == set(), f"members of {name} missing from _core.pyi"
    assert {n for n in classes[name] if not n.startswith("_")} - members == set(), (
        f"members in _core.pyi that {name} lacks")


def _without_constant_values(source):
    """The stub's syntax tree, module-level constants by name only (the shipped stub leaves out
    their values, which depend on the build, and refines their types by hand)."""
    tree = ast.parse(source)
    for node in tree.body:
        if isinstance(node, ast.AnnAssign):
            node.value = node.annotation = None
    return ast.dump(tree)


def test_stub_matches_a_fresh_generation(tmp_path):
    """Signatures too, not only names: where pybind11-stubgen is installed (a dev tool), a fresh
    stub of the installed module equals the shipped one but for comments and constants."""
    pytest.importorskip("pybind11_stubgen")
    subprocess.run([sys.executable, "-m", "pybind11_stubgen", "tsubu._core", "-o", str(tmp_path)],
                   check=True, capture_output=True)
    with open(tmp_path / "tsubu" / "_core.pyi") as f:
        fresh = f.read()
    with open(STUB) as f:
        shipped = f.read()
    assert _without_constant_values(shipped) == _without_constant_values(fresh), (
        "python/tsubu/_core.pyi is stale: regenerate it (see its header)")
