"""The API reference cannot silently miss a name: every public class, function, property and
module of tsubu has a docstring that mentions its parameters, every public name is on a page of
docs/api, and the getting-started guide's code runs as written.

The reference itself is built by Sphinx from these docstrings (docs/api; .ci/run builds it with
-W); these checks need no Sphinx."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import types
from pathlib import Path

import pytest

import tsubu

ROOT = Path(__file__).resolve().parent.parent
API_PAGES = ROOT / "docs" / "api"
GUIDE = API_PAGES / "getting_started.md"


def _own_doc(obj) -> str:
    """The docstring written for ``obj`` (not one inherited, nor one that dataclasses and
    namedtuples generate from the signature)."""
    doc = obj.__dict__.get("__doc__") if isinstance(obj, type) else getattr(obj, "__doc__", None)
    doc = (doc or "").strip()
    if isinstance(obj, type) and doc.startswith(obj.__name__ + "("):
        return ""  # dataclasses.dataclass and typing.NamedTuple's "Name(field, ...)"
    return doc


def _module_data_doc(module: types.ModuleType, name: str) -> str:
    """The ``#:`` comment above (or the string literal below) a module-level assignment: what
    autodoc's ``autodata`` shows."""
    source = inspect.getsource(module)
    lines = source.splitlines()
    body = ast.parse(source).body
    for k, node in enumerate(body):
        targets = node.targets if isinstance(node, ast.Assign) else (
            [node.target] if isinstance(node, ast.AnnAssign) else [])
        if not any(isinstance(t, ast.Name) and t.id == name for t in targets):
            continue
        comment = []
        line = node.lineno - 2
        while line >= 0 and lines[line].lstrip().startswith("#:"):
            comment.insert(0, lines[line].lstrip()[2:].strip())
            line -= 1
        if comment:
            return " ".join(comment)
        after = body[k + 1] if k + 1 < len(body) else None
        if (isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)):
            return after.value.value.strip()
    return ""


def _directives() -> set[tuple[str, str]]:
    """(directive, target) of every autodoc directive in docs/api."""
    found = set()
    for page in list(API_PAGES.rglob("*.rst")) + list(API_PAGES.rglob("*.md")):
        for directive, target in re.findall(r"^\s*(?:\.\. |```\{)(auto\w+)::?\}?\s+(\S+)",
                                            page.read_text(encoding="utf-8"), re.M):
            found.add((directive, target))
    return found


def _reference_modules() -> list[str]:
    """The modules docs/api documents with automodule (besides the package itself)."""
    return sorted(target for directive, target in _directives()
                  if directive == "automodule" and target != "tsubu")


def _listed_members() -> dict[str, list[str]]:
    """The modules whose automodule lists its members (``:members: a, b``): those members."""
    listed = {}
    for page in API_PAGES.rglob("*.rst"):
        text = page.read_text(encoding="utf-8")
        for module, options in re.findall(r"^\.\. automodule:: (\S+)\n((?:[ \t]+:.*\n)*)", text, re.M):
            members = re.search(r":members:[ \t]*(\S.*)", options)
            if members:
                listed[module] = [m.strip() for m in members.group(1).split(",")]
    return listed


def _public_modules() -> list[types.ModuleType]:
    """The modules in ``tsubu.__all__``, and those the reference pages document (those not
    written yet left out: they are in no ``__all__``)."""
    modules = {m.__name__: m for m in (getattr(tsubu, n) for n in tsubu.__all__)
               if isinstance(m, types.ModuleType)}
    for name in _reference_modules():
        if name not in modules:
            try:
                modules[name] = importlib.import_module(name)
            except ModuleNotFoundError as error:
                if error.name != name:
                    raise  # the module exists but fails to import
    return [modules[name] for name in sorted(modules)]


def _public_names_of(module: types.ModuleType) -> list[str]:
    """The members its reference page lists, or else the module's ``__all__``, or else the
    public names it defines itself."""
    listed = _listed_members()
    if module.__name__ in listed:
        return listed[module.__name__]
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return sorted(n for n, v in vars(module).items() if not n.startswith("_")
                  and getattr(v, "__module__", None) == module.__name__)


def _documented_objects():
    """(qualified name, object, owner module) of every public thing of tsubu: the names in
    ``tsubu.__all__``, the public names of the modules among them, and the public methods and
    properties of every class among those."""
    found = []
    for name in tsubu.__all__:
        found.append((f"tsubu.{name}", getattr(tsubu, name), tsubu))
    for module in _public_modules():
        for name in _public_names_of(module):
            found.append((f"{module.__name__}.{name}", getattr(module, name), module))
    members = []
    for qualname, obj, _ in found:
        if isinstance(obj, type):
            for member_name, member in _public_members(obj):
                members.append((f"{qualname}.{member_name}", member, None))
    return found + members


def _public_members(cls: type):
    """The public methods and properties that tsubu's own classes define (inherited ones from
    tsubu's base classes included; those of object, Exception, tuple left out)."""
    seen = set()
    for klass in cls.__mro__:
        if not klass.__module__.startswith("tsubu"):
            continue
        for name, member in vars(klass).items():
            if name.startswith("_") or name in seen:
                continue
            seen.add(name)
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            if isinstance(member, property) or inspect.isfunction(member):
                yield name, member


def _is_data(obj) -> bool:
    """A module-level value (a flag, a version string), documented by a ``#:`` comment."""
    return not (isinstance(obj, (type, types.ModuleType, property)) or callable(obj))


def test_the_public_api_is_what_the_reference_lists():
    # The core names the reference pages document explicitly (a typo in __all__ would hide them).
    for name in ("Simulation", "Material", "InstabilityError", "openmp", "__version__"):
        assert name in tsubu.__all__
        assert hasattr(tsubu, name)
    for name in tsubu.__all__:
        assert hasattr(tsubu, name), f"tsubu.__all__ lists {name!r}, which tsubu does not have"


@pytest.mark.parametrize("qualname, obj, module",
                         [pytest.param(*found, id=found[0]) for found in _documented_objects()])
def test_every_public_name_has_a_docstring(qualname, obj, module):
    if _is_data(obj):
        doc = _module_data_doc(module, qualname.rsplit(".", 1)[1])
        assert doc, (f"{qualname} has no doc comment: write '#: what it is' on the line above its "
                     "assignment (autodoc's autodata shows it)")
        return
    assert _own_doc(obj), f"{qualname} has no docstring"


def _signature_parameters(obj, forwarded: bool = False) -> list[str]:
    """The parameter names a caller writes (self, cls and the private ones left out; ``*args``
    and ``**kwargs`` only with ``forwarded``)."""
    if isinstance(obj, type):
        if issubclass(obj, tuple) and hasattr(obj, "_fields"):  # a NamedTuple: its fields
            return list(obj._fields)
        obj = obj.__init__
        if obj is object.__init__:
            return []
    try:
        signature = inspect.signature(obj)
    except (TypeError, ValueError):  # a builtin without a signature
        return []
    return [p.name for p in signature.parameters.values()
            if p.name not in ("self", "cls") and not p.name.startswith("_")
            and (forwarded or p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD))]


# The run-loop hook protocol (python/tsubu/hooks.py documents its one argument, the Simulation).
HOOK_METHODS = ("next_step", "act", "close")


_SECTION = re.compile(r"^(Parameters|Other Parameters)\n-+\n(.*?)(?=\n[^\n]+\n-{3,}\n|\Z)",
                      re.S | re.M)
# Roles (:meth:`x`), literals (``a: b``) and links, in which napoleon ignores colons.
_NOT_A_FIELD = re.compile(r":[\w:.+-]+:`[^`]*`|``.+?``|`[^`]*`")
_BARE_COLON = re.compile(r"(?<!:):(?!:)")


def _field_name(line: str) -> str:
    """What napoleon takes for the name of the entry a line starts: the text before its first
    colon outside roles and literals (all of it when there is none)."""
    masked = _NOT_A_FIELD.sub(lambda m: "x" * len(m.group()), line)
    colon = _BARE_COLON.search(masked)
    return (line[:colon.start()] if colon else line).strip()


def _documented_parameters(doc: str) -> list[str]:
    """The names of the entries of the docstring's numpy-style Parameters sections, as napoleon
    reads them: every line at the entries' indentation starts an entry, up to the next section
    header, so a paragraph of prose there is read as an entry too (and rendered as one)."""
    doc = inspect.cleandoc(doc)
    names = []
    for match in _SECTION.finditer(doc):
        for line in match.group(2).splitlines():
            if line and not line[0].isspace():
                name = _field_name(line)
                if re.fullmatch(r"\*{0,2}\w+(\s*,\s*\*{0,2}\w+)*", name):
                    names += [n.strip().lstrip("*") for n in name.split(",")]
                else:
                    names.append(name)
    return names


def _callables():
    for qualname, obj, _ in _documented_objects():
        if isinstance(obj, property) or _is_data(obj) or isinstance(obj, types.ModuleType):
            continue
        yield qualname, obj


@pytest.mark.parametrize("qualname, obj", [pytest.param(q, o, id=q) for q, o in _callables()])
def test_docstrings_describe_the_real_parameters(qualname, obj):
    """Every parameter is mentioned in its docstring, and a Parameters section names no
    parameter that does not exist (a renamed argument leaves none behind)."""
    doc = _own_doc(obj)
    parameters = _signature_parameters(obj)
    if qualname.rsplit(".", 1)[1] in HOOK_METHODS and parameters == ["sim"]:
        parameters = []
    missing = [p for p in parameters if not re.search(rf"\b{re.escape(p)}\b", doc)]
    assert not missing, f"{qualname}: the docstring does not mention {missing}"
    documented = _documented_parameters(doc)
    if documented:
        # (*args and **kwargs need not be mentioned, as they may be forwarded, but may be.)
        real = _signature_parameters(obj, forwarded=True)
        stale = [p for p in documented if p not in real]
        assert not stale, (f"{qualname}: the Parameters section names {stale}, not in {real} (a "
                           "line of prose at the entries' indentation reads as an entry)")


@pytest.mark.parametrize("qualname, prop", [pytest.param(q, o, id=q) for q, o, _ in
                                            _documented_objects() if isinstance(o, property)])
def test_property_summaries_have_no_bare_colon(qualname, prop):
    """napoleon reads a property docstring's first line "x: y" as "type: description", which
    renders the summary as a type: keep colons out of that line."""
    first = (_own_doc(prop).splitlines() or [""])[0]
    assert ":" not in _NOT_A_FIELD.sub("", first), (
        f"{qualname}: the first line {first!r} has a colon, which napoleon takes for 'type: "
        "description'")


def test_every_public_name_is_on_a_reference_page():
    directives = _directives()
    targets = {target for _, target in directives}
    modules = {target for directive, target in directives if directive == "automodule"}
    for name in tsubu.__all__:
        obj = getattr(tsubu, name)
        if isinstance(obj, types.ModuleType):
            assert obj.__name__ in modules, f"docs/api has no automodule for {obj.__name__}"
        elif getattr(obj, "__module__", "tsubu") in modules and not _is_data(obj):
            pass  # documented on its module's page (tsubu.insert.Inserter)
        else:
            assert f"tsubu.{name}" in targets, f"docs/api documents no tsubu.{name}"
    for module in ("tsubu.fill", "tsubu.insert", "tsubu.output", "tsubu.scene"):
        assert module in modules, f"docs/api has no automodule for {module}"
    assert set(_reference_modules()) <= modules


def _guide_blocks(language: str) -> list[str]:
    text = GUIDE.read_text(encoding="utf-8")
    return re.findall(rf"^```{language}\n(.*?)^```", text, re.S | re.M)


def test_the_guide_has_its_parts():
    text = GUIDE.read_text(encoding="utf-8")
    for part in ("pip install", "VTKOutput", ".pvd", "Tube", "Simulation.load", ".save(",
                 "tsubu run", "tsubu resume"):
        assert part in text, f"getting_started.md says nothing of {part!r}"
    assert _guide_blocks("python") and _guide_blocks("toml")


def test_the_guide_scene_file_is_valid_toml():
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    (scene,) = _guide_blocks("toml")
    parsed = tomllib.loads(scene)
    assert {"simulation", "materials", "walls", "particles"} <= set(parsed)
    scene_module = pytest.importorskip("tsubu.scene", reason="tsubu.scene is not merged yet")
    scene_module.validate(parsed, "getting_started.md")  # SceneError names any bad key


def test_the_guide_runs_as_written(tmp_path, monkeypatch):
    """The guide's Python blocks, one after the other in an empty folder (a few seconds)."""
    for module in ("tsubu.fill", "tsubu.output"):
        pytest.importorskip(module, reason=f"{module} is not merged yet")
    if not hasattr(tsubu.Simulation, "save"):
        pytest.skip("checkpoints (Simulation.save) are not merged yet")
    monkeypatch.chdir(tmp_path)
    code = "\n".join(_guide_blocks("python"))
    namespace: dict = {"__name__": "getting_started"}
    exec(compile(code, str(GUIDE), "exec"), namespace)
    sim = namespace["sim"]
    assert sim.size == 300 and sim.time > 0.2
    assert (tmp_path / "out" / "particles.pvd").is_file()
    assert (tmp_path / "heap.tsubu").is_file()
    assert namespace["restarted"].step_count == sim.step_count
