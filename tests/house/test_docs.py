"""The documentation says what the code does: every `>>>` block is a doctest; every link resolves
(files and headings); every `roar ...` command line is one its command accepts, every `make`
target exists and every `python -m` module imports; every Python example compiles and imports
what exists; every `roar...` name in backticks names a module or attribute that is there."""

import ast
import doctest
import importlib
import importlib.util
import re
import shlex
from pathlib import Path

import pytest

from conftest import ROOT
from roar.cli.sdk import EXIT_MEANINGS, UserError

DOCS = sorted(["README.md", "host/README.md", "hil_sim/README.md", "firmware/README.md", "firmware/micropython/README.md",
               "tests/README.md",
               "protocol/PROTOCOL.md", *(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))])
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
NAME = re.compile(r"`[^`\n]*?\b((?:roar|roar_sim|roar_wire)(?:\.[A-Za-z_]\w*)+)")
ENTRY_POINT_GROUPS = {"roar.commands"}  # names that are entry-point groups, not modules


def text(name: str) -> str:
    return (ROOT / name).read_text()


def blocks(name: str, languages: tuple[str, ...]) -> list[str]:
    return [body for lang, body in FENCE.findall(text(name)) if lang in languages]


def outside_code(name: str) -> str:
    return FENCE.sub("", text(name))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    body = FENCE.sub("", path.read_text())
    return {slug(m) for m in re.findall(r"^#+ (.*)$", body, re.M)}


def test_the_docs_are_the_ones_listed_and_the_readme_stays_short():
    assert "docs/README.md" in DOCS and len(DOCS) >= 15
    assert len(text("README.md")) < 6000  # the first screen: what it is, two commands, the example, the fleet, links
    first = text("README.md").split("```")[1]
    assert first.split("\n")[1].startswith("make run") and first.split("\n")[2].startswith("make test")


@pytest.mark.parametrize("name", DOCS)
def test_examples_run_as_shown(name):
    parser, runner = doctest.DocTestParser(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for i, block in enumerate(b for b in blocks(name, ("python",)) if ">>>" in b):
        runner.run(parser.get_doctest(block, {}, f"{name}[{i}]", name, 0))
    assert runner.failures == 0, f"{runner.failures} example(s) in {name} do not match the code (see output)"


def test_the_main_readme_has_a_checked_example():
    assert any(">>>" in b for b in blocks("README.md", ("python",)))


@pytest.mark.parametrize("name", DOCS)
def test_links_resolve_to_files_and_headings(name):
    broken = []
    for target in LINK.findall(outside_code(name)):
        if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        path = (ROOT / name).parent / path_part if path_part else ROOT / name
        if not path.exists():
            broken.append(f"{target}: no such file")
        elif anchor and path.suffix == ".md" and anchor not in anchors(path):
            broken.append(f"{target}: no heading #{anchor} in {path.relative_to(ROOT)}")
    assert broken == []


def test_the_exit_status_table_is_the_one_the_commands_use():
    """host/README.md's table is EXIT_MEANINGS row for row; no doc gives a status another meaning."""
    section = text("host/README.md").split("### Exit statuses", 1)[1]
    rows = re.findall(r"^\| (\d+) \| (.+) \|$", section, re.M)
    assert [(int(code), meaning.replace("\\|", "|")) for code, meaning in rows] == \
        [(int(status), meaning) for status, meaning in EXIT_MEANINGS.items()]
    for name in DOCS:
        for code in re.findall(r"exit(?:s| status| with)? (\d+)", outside_code(name)):
            assert int(code) in {int(s) for s in EXIT_MEANINGS}, f"{name}: exit status {code}"
        assert "argparse's (status 2)" not in text(name)


def command_lines(name: str) -> list[list[str]]:
    """The command lines of the doc's shell blocks, comments dropped."""
    found = []
    for block in blocks(name, ("", "sh", "bash")):
        for line in block.splitlines():
            line = line.strip()
            if line.startswith(("roar ", ".venv/bin/roar ", "make ", "python -m ", ".venv/bin/python -m ")):
                try:
                    found.append(shlex.split(line, comments=True))
                except ValueError:
                    found.append([line])
    return found


def check_command(argv: list[str]) -> str | None:
    """Why the command line is not one that works (None if it is)."""
    cli = importlib.import_module("roar.cli.main")  # the package's `main` is the function

    tool = argv[0].rsplit("/", 1)[-1]
    if tool == "make":
        targets = re.findall(r"^([\w-]+):", (ROOT / "Makefile").read_text(), re.M)
        return None if argv[1] in targets else f"no make target {argv[1]}"
    if tool == "python":
        return None if importlib.util.find_spec(argv[2]) else f"no module {argv[2]}"
    commands = cli.commands()
    try:
        if argv[1] in commands:
            commands[argv[1]].parse_args(argv[2:])
        else:
            cli.parser().parse_args(argv[1:])
    except SystemExit as e:
        return None if e.code == 0 else "its command refuses these arguments"
    except UserError as e:
        return f"its command refuses these arguments: {e}"
    return None


@pytest.mark.parametrize("name", DOCS)
def test_every_command_line_is_one_the_commands_accept(name, capsys):
    lines = command_lines(name)
    refused = [(" ".join(argv), why) for argv in lines if (why := check_command(argv))]
    assert refused == [], capsys.readouterr().err


def test_the_command_lines_are_really_checked():
    assert check_command(["roar", "race", "--robot", "junior", "--laps", "1"]) is None
    assert check_command(["roar", "race", "--junior"]) is not None
    assert check_command(["roar", "sim", "--stream", "--size", "320x240"]) is None
    assert check_command(["make", "nonesuch"]) is not None
    assert sum(len(command_lines(name)) for name in DOCS) > 20


def imports_of(source: str) -> list[tuple[str, str | None]]:
    """(module, name or None) of every import statement."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(a.name, None) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            found += [(node.module, a.name) for a in node.names]
    return found


def resolves(dotted: str) -> bool:
    """A module, or an attribute chain of one."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        module = ".".join(parts[:i])
        try:
            obj = importlib.import_module(module)
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return False
        return True
    return False


@pytest.mark.parametrize("name", DOCS)
def test_python_examples_compile_and_import_what_exists(name):
    missing = []
    for block in blocks(name, ("python",)):
        if ">>>" in block:
            continue
        compile(block, name, "exec")
        for module, attr in imports_of(block):
            if module.split(".")[0] in ("roar", "roar_sim", "roar_wire") and not resolves(
                    module + (f".{attr}" if attr else "")):
                missing.append(f"{module} {attr or ''}")
    assert missing == []


@pytest.mark.parametrize("name", DOCS)
def test_every_named_module_and_attribute_exists(name):
    names = {n.rstrip(".") for n in NAME.findall(text(name))} - ENTRY_POINT_GROUPS
    assert [n for n in sorted(names) if not resolves(n)] == []


def make_targets() -> set[str]:
    return set(re.findall(r"^([\w-]+):", text("Makefile"), re.M))


def test_the_makefile_header_and_the_commands_page_name_every_target_and_command():
    """The Makefile's header comment and docs/commands.md list every make target; commands.md
    lists every roar command, ours and the simulator's, with the module that holds it."""
    from roar.cli.main import BUILT_IN, EXTRA_COMMANDS, commands

    header = re.findall(r"^# make ([\w-]+)", text("Makefile"), re.M)
    assert set(header) == make_targets(), set(header) ^ make_targets()
    page = text("docs/commands.md")
    assert set(re.findall(r"^\| `make ([\w-]+)", page, re.M)) == make_targets()
    listed = dict(re.findall(r"^\| `roar ([\w-]+)[^`]*` \|.*\| `([\w.]+)` \|$", page, re.M))
    installed = commands()
    assert set(listed) == set(installed) == set(BUILT_IN) | set(EXTRA_COMMANDS), set(listed) ^ set(installed)
    assert {name: c.module for name, c in installed.items()} == listed


def test_every_command_has_one_shape():
    """Each roar command is a module with parser() and main(argv), its parser's prog its own name."""
    from roar.cli.main import commands
    from roar.cli.sdk import ArgumentParser, Command

    for name, command in commands().items():
        assert isinstance(command, Command), name
        module = importlib.import_module(command.module)
        assert callable(getattr(module, command.main_name)), name
        for flags, parser in command.parsers().items():
            assert isinstance(parser, ArgumentParser) and parser.prog == " ".join(("roar", name, *flags)), parser.prog
