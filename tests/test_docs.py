"""The documentation a newcomer walks (README.md and docs/) against the code: every command and
every scenario field is documented, every command line quoted in a ``bash`` block parses with
the real parser, every relative link resolves, and the package list of docs/how-it-works.md
matches the imports of feedopt/."""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import re
import shlex
from collections import Counter
from pathlib import Path

import pytest
from pydantic import BaseModel

from feedopt import cli, schema
from feedopt.scenario import Scenario
from feedopt.schedule.laws import LAWS

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.glob("*.md"))
MARKDOWN = [ROOT / "README.md", *PAGES]
PACKAGE = ROOT / "feedopt"

# ---------------------------------------------------------------- (a) commands


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    """Every subcommand of the real ``feedopt`` parser, by name."""
    parser = cli.build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def _spellings(name: str) -> list[str]:
    """How a user writes the command: ``feedopt robot-init`` or ``feedopt robot init``."""
    return [f"feedopt {name}"] + [f"feedopt {' '.join(words)}"
                                  for words, joined in cli._TWO_WORDS.items() if joined == name]


def _mentions(text: str, spellings: list[str]) -> bool:
    # `feedopt robot` must not count as documenting `feedopt robot-init` and vice versa
    return any(re.search(re.escape(s) + r"(?![\w-])", text) for s in spellings)


COMMANDS = _subcommands()


def test_the_parser_has_the_commands_we_expect_to_find() -> None:
    assert {"run", "validate", "path", "sweep", "stream", "robot-init"} <= set(COMMANDS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_is_documented_and_its_help_points_to_its_page(name: str) -> None:
    spellings = _spellings(name)
    documented = [p.name for p in PAGES if _mentions(p.read_text(), spellings)]
    assert documented, f"no page of docs/ mentions {' or '.join(map(repr, spellings))}"
    help_text = COMMANDS[name].format_help()
    pages = re.findall(r"docs/[\w.-]+\.md", help_text)
    assert pages, f"`feedopt {name} --help` names no docs/ page"
    for page in pages:
        assert (ROOT / page).is_file(), f"`feedopt {name} --help` names {page}, which is missing"
    assert any(_mentions((ROOT / page).read_text(), spellings) for page in pages), (
        f"`feedopt {name} --help` points to {pages}, none of which documents the command")


# ------------------------------------------------------------ (b) scenario fields


def _fields(model: type[BaseModel], prefix: str = "") -> list[str]:
    """Dotted names of every field of ``model`` and of its sections, recursively."""
    out = []
    for name, field in model.model_fields.items():
        out.append(prefix + name)
        sub = schema.sub_model(field.annotation)
        if sub is not None:
            out += _fields(sub, f"{prefix}{name}.")
    return out


def scenario_fields() -> list[str]:
    """Every scenario field, the options of every registered timing law included."""
    fields = _fields(Scenario)
    for law, spec in LAWS.items():
        fields += _fields(spec.options_model(), f"schedule.law_options.{law}.")
    return fields


def _sections(text: str) -> list[tuple[str, str]]:
    """(heading, body) of every heading of a markdown page."""
    parts = re.split(r"^(#{1,6} .*)$", text, flags=re.M)
    return list(zip(parts[1::2], parts[2::2], strict=True))


def _documented(field: str, sections: list[tuple[str, str]]) -> bool:
    """``a.b.c`` is documented when the section headed by `a.b` (the top level: a heading
    saying "top level") has a table row for `c`."""
    parent, _, leaf = field.rpartition(".")
    row = re.compile(r"^\|\s*`" + re.escape(leaf) + r"`\s*\|", re.M)
    for heading, body in sections:
        owner = (f"`{parent}`" in heading) if parent else ("top level" in heading.lower())
        if owner and row.search(body):
            return True
    return False


def test_every_scenario_field_is_documented_in_scenario_files() -> None:
    fields = scenario_fields()
    assert {"name", "path.generator", "cut.radial_depth_profile.s_mm", "fits.why",
            "schedule.law_options.convex.max_gridpoints"} <= set(fields)
    sections = _sections((DOCS / "scenario-files.md").read_text())
    missing = [f for f in fields if not _documented(f, sections)]
    assert not missing, f"docs/scenario-files.md lacks a row for: {', '.join(missing)}"


def test_the_field_check_fails_for_an_undocumented_field() -> None:
    sections = _sections("## Top level\n\n| `name` | x |\n\n## `path`\n\n| `file` | y |\n")
    assert _documented("name", sections) and _documented("path.file", sections)
    assert not _documented("path.generator", sections)
    assert not _documented("description", sections)
    assert not _documented("cut.file", sections)  # `file` is a row of `path`, not of `cut`


# ---------------------------------------------------------- (c) quoted command lines

FENCE = re.compile(r"^[ \t]*```bash[ \t]*\n(.*?)^[ \t]*```", re.M | re.S)
CONTROL = {"&&", "||", ";", "|", "&", "|&", ";;"}


def _simple_commands(line: str) -> list[list[str]]:
    """The simple commands of one shell line: split at control operators, redirections and
    their targets removed (quotes respected; ``#`` comments dropped)."""
    line = re.sub(r"(^|\s)\d+(?=[<>])", r"\1", line)  # the fd of 2>&1, 2> file
    lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    commands: list[list[str]] = [[]]
    skip = False
    for token in lexer:
        if skip:
            skip = False
        elif token in CONTROL:
            commands.append([])
        elif set(token) <= set("<>&|") and set(token) & set("<>"):
            skip = True  # a redirection: its target is not an argument
        else:
            commands[-1].append(token)
    return [c for c in commands if c]


def quoted_feedopt_commands() -> list[tuple[str, str, list[str]]]:
    """(file, quoted line, arguments after ``feedopt``) of every ``feedopt`` or
    ``.venv/bin/feedopt`` command in a bash block of README.md and docs/*.md."""
    found = []
    for path in MARKDOWN:
        for block in FENCE.findall(path.read_text()):
            for line in block.replace("\\\n", " ").splitlines():
                for command in _simple_commands(line):
                    if command[0] == "feedopt" or command[0].endswith("/bin/feedopt"):
                        found.append((str(path.relative_to(ROOT)), line.strip(), command[1:]))
    return found


QUOTED = quoted_feedopt_commands()


def test_the_quoted_commands_are_found() -> None:
    files = Counter(f for f, _, _ in QUOTED)
    assert files["README.md"] >= 3  # the two commands' run and the tour
    assert sum(files.values()) >= 40
    assert any(args[:2] == ["run", "scenarios/triangle_slot.yaml"] for f, _, args in QUOTED
               if f == "README.md")


def test_shell_lines_are_split_into_commands() -> None:
    assert _simple_commands("python3 -m venv .venv && .venv/bin/feedopt run s.yaml") == [
        ["python3", "-m", "venv", ".venv"], [".venv/bin/feedopt", "run", "s.yaml"]]
    assert _simple_commands("feedopt sweep s.yaml --grid 'a=1;2' 2>&1 > log.txt | head") == [
        ["feedopt", "sweep", "s.yaml", "--grid", "a=1;2"], ["head"]]
    assert _simple_commands("feedopt run s.yaml   # a comment") == [["feedopt", "run", "s.yaml"]]


def _parse_error(parser: argparse.ArgumentParser, args: list[str]) -> str | None:
    """None when the real parser accepts ``args`` as the console script would, else its
    message."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            namespace = parser.parse_args(cli._two_word_commands(args))
        except SystemExit as exc:
            return None if exc.code in (0, None) else err.getvalue().strip() or str(exc.code)
    return None if getattr(namespace, "func", None) else "no command given"


@pytest.fixture(scope="module")
def parser() -> argparse.ArgumentParser:
    return cli.build_parser()


@pytest.mark.parametrize(("where", "line", "args"), QUOTED,
                         ids=[f"{f}:{' '.join(a)[:60]}" for f, _, a in QUOTED])
def test_every_quoted_command_line_parses(parser, where: str, line: str,
                                          args: list[str]) -> None:
    problem = _parse_error(parser, args)
    assert problem is None, f"{where}: the quoted command does not parse:\n  {line}\n{problem}"


def test_the_parse_check_catches_a_bad_command_line(parser) -> None:
    assert _parse_error(parser, ["run", "s.yaml", "--no-such-flag"]) is not None
    assert _parse_error(parser, ["robot", "init", "x.urdf"]) is not None  # --out is required
    assert _parse_error(parser, []) == "no command given"
    assert _parse_error(parser, ["robot", "init", "x.urdf", "--out", "d"]) is None


def test_the_readme_is_short_and_its_test_command_is_what_ci_runs() -> None:
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) < 250
    section = text.split("\n## Two commands\n", 1)[1].split("\n## ", 1)[0]
    run, test = (block.strip() for block in FENCE.findall(section))
    assert run.endswith(".venv/bin/feedopt run scenarios/triangle_slot.yaml")
    assert test == (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]


# ------------------------------------------------------------------ (d) links

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def _slugs(text: str) -> set[str]:
    """GitHub's anchors of the headings of a markdown page."""
    seen: Counter[str] = Counter()
    out = set()
    for heading, _ in _sections(FENCE.sub("", text)):
        slug = re.sub(r"[^\w\- ]", "", heading.lstrip("#").strip().lower()).replace(" ", "-")
        out.add(slug if not seen[slug] else f"{slug}-{seen[slug]}")
        seen[slug] += 1
    return out


def _links(path: Path) -> list[str]:
    text = re.sub(r"^[ \t]*```.*?^[ \t]*```", "", path.read_text(), flags=re.M | re.S)
    text = re.sub(r"`[^`\n]*`", "", text)  # inline code is not a link
    return LINK.findall(text)


def _broken_links(path: Path, root: Path = ROOT) -> tuple[int, list[str]]:
    """How many relative links ``path`` has, and those that do not point to a file (or a
    heading of a page) inside ``root``."""
    broken, count = [], 0
    for target in _links(path):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        count += 1
        name, _, anchor = target.partition("#")
        dest = (path.parent / name).resolve() if name else path
        where = f"{path.relative_to(root)} -> {target}"
        if not dest.is_relative_to(root) or not dest.exists():
            broken.append(f"{where}: no such file in the repository")
        elif anchor and dest.suffix == ".md" and anchor not in _slugs(dest.read_text()):
            broken.append(f"{where}: no heading #{anchor} in {dest.name}")
    return count, broken


def test_every_relative_link_points_to_an_existing_file() -> None:
    results = [_broken_links(path) for path in MARKDOWN]
    broken = [b for _, bs in results for b in bs]
    assert sum(n for n, _ in results) >= 30
    assert not broken, "\n".join(broken)


def test_the_link_check_finds_missing_files_headings_and_links_out_of_the_repository(
        tmp_path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "b.md").write_text("# B\n## Some part\n")
    page = tmp_path / "docs" / "a.md"
    page.write_text("[ok](b.md#some-part) [gone](c.md) [heading](b.md#other) "
                    "[out](../../x.md) [web](https://example.org) `[code](d.md)`\n")
    count, broken = _broken_links(page, tmp_path)
    assert count == 4
    assert [b.split(" -> ")[1].split(":")[0] for b in broken] == [
        "c.md", "b.md#other", "../../x.md"]


def test_the_index_links_every_page() -> None:
    linked = {target.partition("#")[0] for target in _links(DOCS / "README.md")}
    assert {p.name for p in PAGES} - {"README.md"} <= linked


def test_the_slugs_are_githubs() -> None:
    text = "# A page\n## The rotation about the tool axis (`robot.redundancy`)\n## Cost\n## Cost\n"
    assert _slugs(text) == {"a-page", "the-rotation-about-the-tool-axis-robotredundancy",
                            "cost", "cost-1"}


# --------------------------------------------------- the layout picture of record


def _unit(path: Path) -> str:
    """The package or top-level module of feedopt/ a source file belongs to."""
    parts = path.relative_to(PACKAGE).parts
    return parts[0] if len(parts) > 1 else parts[0].removesuffix(".py")


UNITS = sorted({_unit(p) for p in PACKAGE.rglob("*.py")} - {"__init__"})


def _imported_units(path: Path, source: str | None = None) -> set[str]:
    """The other feedopt units the file at ``path`` (its text: ``source``, else read) imports
    at run time (``if TYPE_CHECKING:`` excluded)."""
    tree = ast.parse(path.read_text() if source is None else source)
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(block.test) for n in ast.walk(block)}
    package = list(path.relative_to(ROOT).parent.parts)
    out = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            names = [module] + [f"{module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "feedopt" and len(parts) > 1 and parts[1] in UNITS:
                out.add(parts[1])
    return out - {_unit(path)}


def actual_imports() -> dict[str, set[str]]:
    out: dict[str, set[str]] = {u: set() for u in UNITS}
    for path in PACKAGE.rglob("*.py"):
        if _unit(path) in out:
            out[_unit(path)] |= _imported_units(path)
    return out


def documented_layout() -> dict[str, set[str]]:
    """unit -> what it may import, from the bullets of "The packages" in how-it-works.md."""
    text = (DOCS / "how-it-works.md").read_text()
    body = next(b for h, b in _sections(text) if h.strip() == "## The packages")
    out = {}
    for bullet in re.findall(r"^- \*\*([\w.]+?)(?:/|\.py)\*\* (.*)$", body, flags=re.M):
        name, sentence = bullet
        assert "may import" in sentence or "imports nothing else" in sentence, name
        allowed = sentence.partition("may import")[2]
        out[name] = set(re.findall(r"`(\w+)`", allowed))
    return out


def test_the_layout_picture_has_one_line_per_package_and_matches_the_imports() -> None:
    layout, actual = documented_layout(), actual_imports()
    assert sorted(layout) == UNITS, (
        f"docs/how-it-works.md 'The packages' lists {sorted(set(layout) - set(UNITS))} that "
        f"do not exist and lacks {sorted(set(UNITS) - set(layout))}")
    extra = {u: sorted(actual[u] - layout[u]) for u in UNITS if actual[u] - layout[u]}
    assert not extra, ("imports that docs/how-it-works.md 'The packages' does not allow "
                       f"(add them there, or remove the import): {extra}")


def test_the_import_reader_sees_relative_lazy_and_typing_only_imports() -> None:
    source = ("from typing import TYPE_CHECKING\nfrom ..errors import InputError\n"
              "from . import path\nif TYPE_CHECKING:\n    from feedopt.robot import model\n"
              "def f():\n    from feedopt.units import MM\n    import feedopt.gcode\n")
    assert _imported_units(PACKAGE / "geometry" / "x.py", source) == {"errors", "units", "gcode"}
