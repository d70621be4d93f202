"""The house stays in order (docs/layout.md): the simulator's top level shows its rooms and no
more, and no module of the project imports, at module level or inside a function, one that
imports it back."""

import ast
import graphlib
from pathlib import Path

from conftest import ROOT

PACKAGES = [ROOT / "host", ROOT / "hil_sim"]  # where the project's importable packages live
MAX_TOP_LEVEL = 12


def test_the_simulator_shows_its_rooms_at_the_top_and_no_more():
    entries = sorted(p.name for p in (ROOT / "hil_sim" / "roar_sim").iterdir() if p.name != "__pycache__")
    assert len(entries) <= MAX_TOP_LEVEL, entries
    assert {"robots", "links", "runs", "gym_env"} <= set(entries)


def modules() -> dict[str, Path]:
    found = {}
    for base in PACKAGES:
        for path in base.rglob("*.py"):
            parts = path.relative_to(base).with_suffix("").parts
            if not (base / parts[0] / "__init__.py").exists():  # scripts and stand-ins, not packages
                continue
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


def imports(name: str, path: Path, known: dict[str, Path]) -> set[str]:
    """The project's modules that `name` imports, wherever in the module the import is."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            submodules = {f"{base}.{a.name}" for a in node.names} & set(known)
            out |= submodules if submodules else {base}
    return {m for m in out if m in known and m != name}


def test_no_import_cycles_among_the_projects_modules():
    known = modules()
    assert {"roar.vehicle", "roar_sim.robots", "roar_wire.control"} <= set(known)
    graph = {name: imports(name, path, known) for name, path in known.items()}
    try:
        order = list(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as e:
        raise AssertionError(f"import cycle: {' -> '.join(e.args[1])}") from None
    assert len(order) == len(known)


def test_the_cycle_check_sees_a_cycle(tmp_path):
    """A package whose two modules import each other, one inside a function, is caught."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from pkg import b\n")
    (package / "b.py").write_text("def f():\n    from pkg.a import thing\n")
    known = {"pkg": package / "__init__.py", "pkg.a": package / "a.py", "pkg.b": package / "b.py"}
    graph = {name: imports(name, path, known) for name, path in known.items()}
    assert graph["pkg.a"] == {"pkg.b"} and graph["pkg.b"] == {"pkg.a"}
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError:
        return
    raise AssertionError("the cycle went unseen")
