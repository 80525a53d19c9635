"""The core's layout keeps the promises of docs/architecture.md: one type per concern, the engine
free of the Simulation, contact laws named only where laws live, and files small enough to read.

These read the C++ sources as text; they fail when a change breaks a rule, naming the file."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CPP = ROOT / "cpp"
SOURCES = sorted(
    p for folder in (CPP, ROOT / "tests" / "cpp", ROOT / "examples" / "cpp")
    for p in folder.rglob("*") if p.suffix in {".cpp", ".hpp", ".inc"}
)
if not SOURCES:  # an installed package without its sources
    pytest.skip("the C++ sources are not here", allow_module_level=True)


def code_of(path: Path) -> str:
    """The file without its comments (a comment may name anything)."""
    text = path.read_text()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def law_types() -> set[str]:
    """Every evaluator of every slot, as registry.hpp's type lists name them."""
    registry = code_of(CPP / "include" / "tsubu" / "registry.hpp")
    names = set()
    for body in re.findall(r"using \w+Laws = TypeList<(.*?)>;", registry, flags=re.S):
        names |= {n.strip() for n in body.split(",") if n.strip() and "<" not in n}
    return names


def test_no_cpp_file_is_over_600_lines():
    long = {str(p.relative_to(ROOT)): n for p in SOURCES if (n := len(p.read_text().splitlines())) > 600}
    assert not long, f"C++ files over 600 lines: {long}"


def test_the_engine_does_not_include_the_simulation():
    engine = CPP / "include" / "tsubu" / "engine"
    offenders = [p.name for p in engine.glob("*.hpp") if re.search(r'#include\s+"[./]*simulation\.hpp"', p.read_text())]
    assert not offenders, f"engine headers including simulation.hpp: {offenders}"
    assert not re.search(r"\bSimulation\b", "".join(code_of(p) for p in engine.glob("*.hpp")))


def test_only_the_laws_name_a_law():
    laws = law_types()
    assert {"HookeNormal", "HertzNormal", "MindlinRotate", "NoTangential"} <= laws
    # Where a law may be named: the laws themselves (contact/), the registry that lists them, the
    # Material and PairParams that carry every law's parameter set, and the bindings' two helpers
    # for the Hertzian dashpot's restitution (a law's own closed form, exposed to Python).
    allowed = {"registry.hpp", "material.hpp", "register_materials.cpp"}
    offenders = {}
    for path in SOURCES:
        if "contact" in path.parts or path.name in allowed or "tests" in path.parts:
            continue
        named = sorted(n for n in laws if re.search(rf"\b{n}\b", code_of(path)))
        if named:
            offenders[str(path.relative_to(ROOT))] = named
    assert not offenders, f"files outside contact/ naming a law: {offenders}"
