"""The house stays in order (docs/layout.md): every import goes where the floors table allows, no
module imports one that imports it back, the doc names every module in its room's entry, the
simulator's top level shows its rooms and no more, and flashing a board needs no simulator.
Imports are read wherever they are, at module level or inside a function."""

import ast
import graphlib
import re
from pathlib import Path

import pytest

from conftest import ROOT

PACKAGES = {"roar": ROOT / "host", "roar_wire": ROOT / "host", "roar_sim": ROOT / "hil_sim"}  # name: where it lives
MAX_TOP_LEVEL = 12
LAYOUT = ROOT / "docs" / "layout.md"
# what each package may import of the others (a package always imports itself, by the floors)
PACKAGE_RULES = {"roar_wire": set(), "roar": {"roar_wire"}, "roar_sim": {"roar", "roar_wire"}}
TABLE_ROW = re.compile(r"^\| `(\w+)` \| (\d+) \| ([^|]+) \| (yes|no) \|$", re.M)
PLANNED = "*"  # a room of the table that is to come


# --- the tree and its imports -----------------------------------------------------------------

def modules(packages: dict[str, Path] = PACKAGES) -> dict[str, Path]:
    """Every module of the packages: dotted name -> file."""
    found = {}
    for package, base in packages.items():
        for path in (base / package).rglob("*.py"):
            parts = (package, *path.relative_to(base / package).with_suffix("").parts)
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
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


def room(module: str) -> tuple[str, str]:
    """(package, room): a subpackage or a top-level module; the package's own __init__ is "__init__"."""
    parts = module.split(".")
    return parts[0], parts[1] if len(parts) > 1 else "__init__"


# --- the floors table -------------------------------------------------------------------------

def floors(text: str) -> dict[tuple[str, str], tuple[int, bool]]:
    """(package, room) -> (its floor, whether rooms of that floor may import each other)."""
    table = {}
    for package, floor, rooms, peers in TABLE_ROW.findall(text):
        for name in rooms.replace("\\", "").split(","):
            table[package, name.strip()] = (int(floor), peers == "yes")
    return table


def violations(graph: dict[str, set[str]], table: dict[tuple[str, str], tuple[int, bool]]) -> list[str]:
    """Every import the table does not allow, in words."""
    found = []
    for module, targets in sorted(graph.items()):
        (package, here), place = room(module), table.get(room(module))
        for target in sorted(targets):
            (other_package, there) = room(target)
            if other_package != package:
                if other_package not in PACKAGE_RULES[package]:
                    found.append(f"{module} imports {target}: {package} never imports {other_package}")
                continue
            if here == there:
                continue
            other = table.get(room(target))
            if place is None or other is None:
                continue  # a room with no floor: reported by its own test
            if other[0] > place[0] or (other[0] == place[0] and not place[1]):
                found.append(f"{module} imports {target}: {package}.{here} (floor {place[0]}) may not import "
                             f"{package}.{there} (floor {other[0]})")
    return found


@pytest.fixture(scope="module")
def graph():
    known = modules()
    return {name: imports(name, path, known) for name, path in known.items()}


def test_every_import_goes_where_the_floors_allow(graph):
    table = floors(LAYOUT.read_text())
    assert {"roar", "roar_wire", "roar_sim"} == {p for p, _ in table}
    assert violations(graph, table) == []


def test_every_room_has_a_floor_and_every_floor_room_is_there():
    table = floors(LAYOUT.read_text())
    rooms = {room(m) for m in modules()}
    assert sorted(rooms - set(table)) == [], "rooms with no floor in docs/layout.md"
    planned = {r for r in set(table) - rooms if r[1].endswith(PLANNED)}
    assert sorted(set(table) - rooms - planned) == [], "floors name rooms that are not there"


def test_the_floors_check_catches_what_it_should():
    """A room importing one above it, a peer on a floor that keeps its peers apart, roar importing
    roar_sim and roar_wire importing roar are each caught; what the table allows is not."""
    table = floors("| `roar` | 1 | errors | no |\n| `roar` | 2 | tracks, vision | no |\n"
                   "| `roar` | 3 | cli, web | yes |\n| `roar_sim` | 1 | runs | no |\n| `roar_wire` | 1 | spec | no |\n")
    graph = {"roar.errors": {"roar.tracks.track"}, "roar.tracks.track": {"roar.vision.lanes", "roar.errors"},
             "roar.cli.main": {"roar.web.server", "roar_sim.runs.race"}, "roar_wire.spec": {"roar.errors"},
             "roar_sim.runs.race": {"roar.cli.main", "roar_wire.spec"}}
    found = violations(graph, table)
    assert len(found) == 4, found
    assert [f.split(":")[0] for f in found] == ["roar.cli.main imports roar_sim.runs.race", "roar.errors imports roar.tracks.track",
                                                "roar.tracks.track imports roar.vision.lanes", "roar_wire.spec imports roar.errors"]


def test_no_import_cycles_among_the_projects_modules(graph):
    assert {"roar.vehicle", "roar_sim.robots", "roar_wire.control"} <= set(graph)
    try:
        order = list(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as e:
        raise AssertionError(f"import cycle: {' -> '.join(e.args[1])}") from None
    assert len(order) == len(graph)


def test_the_cycle_check_sees_a_cycle(tmp_path):
    """A package whose two modules import each other, one inside a function, is caught."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from pkg import b\n")
    (package / "b.py").write_text("def f():\n    from pkg.a import thing\n")
    known = modules({"pkg": tmp_path})
    graph = {name: imports(name, path, known) for name, path in known.items()}
    assert graph["pkg.a"] == {"pkg.b"} and graph["pkg.b"] == {"pkg.a"}
    with pytest.raises(graphlib.CycleError):
        graphlib.TopologicalSorter(graph).prepare()


# --- the tree in the doc ----------------------------------------------------------------------

PACKAGE_LINE = {"host/roar/": "roar", "host/roar_wire/": "roar_wire", "hil_sim/roar_sim/": "roar_sim"}


def entries(text: str) -> dict[tuple[str, str], str]:
    """(package, room) -> the words of its entry in the doc's tree (its line and those under it)."""
    tree = text.split("```", 2)[1]
    found, package, current = {}, None, None
    for line in tree.splitlines():
        if line and not line.startswith(" "):
            package = next((p for prefix, p in PACKAGE_LINE.items() if line.startswith(prefix)), None)
            current = None
        elif package and line.startswith("  ") and not line.startswith("   "):
            heads = re.split(r"\s{2,}", line.strip(), maxsplit=1)[0]
            current = [(package, h.strip().rstrip("/")) for h in heads.split(",")]
            for key in current:
                found[key] = line
        elif package and current:
            for key in current:
                found[key] += " " + line
    return found


def test_the_doc_names_every_module_in_its_rooms_entry():
    listed = entries(LAYOUT.read_text())
    missing = []
    for module in modules():
        package, name = room(module)
        stem = module.rsplit(".", 1)[-1]
        if (package, name) not in listed and name != "__init__":
            missing.append(f"{package}.{name}: no entry")
        elif module.count(".") >= 2 and not re.search(rf"\b{re.escape(stem)}\b", listed[package, name]):
            missing.append(f"{module}: not named in {package}.{name}'s entry")
    assert missing == []


def test_the_simulator_shows_its_rooms_at_the_top_and_no_more():
    entries_ = sorted(p.name for p in (ROOT / "hil_sim" / "roar_sim").iterdir() if p.name != "__pycache__")
    assert len(entries_) <= MAX_TOP_LEVEL, entries_
    assert {"robots", "links", "runs", "gym_env"} <= set(entries_)


def test_flashing_a_board_needs_no_simulator():
    """firmware/deploy.py and the board list it reads import neither roar_sim nor anything of hil_sim/."""
    for path in (ROOT / "firmware" / "deploy.py", ROOT / "firmware" / "micropython" / "board_files.py"):
        source = path.read_text()
        names = {a.name for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Import) for a in n.names}
        names |= {n.module or "" for n in ast.walk(ast.parse(source)) if isinstance(n, ast.ImportFrom)}
        assert not any(n.split(".")[0] == "roar_sim" for n in names) and "hil_sim" not in source, path
