"""The type stubs shipped with the package (python/tsubu/_core.pyi) describe the compiled module:
every public name of tsubu._core and of its classes is in the stub, and the stub names nothing
the module does not have. A stub that falls behind the bindings fails here."""

import ast
import inspect
import os

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
