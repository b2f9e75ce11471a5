"""The README stays true: its Python block runs as shown, every ``tactile-synth``
command it names (in its bash blocks, its inline code and its command table) is a real
sub-command that accepts the options shown, its docs index lists exactly the pages of
docs/, and its paper rows are the paper's Table I as ``benchmark.paper_reference`` holds
it."""

from __future__ import annotations

import argparse
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from benchmark.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^ *```{language}\n(.*?)^ *```", README, flags=re.S | re.M)


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _options(parser: argparse.ArgumentParser) -> set[str]:
    """The option strings of ``parser`` and of its sub-commands, recursively."""
    found = {s for a in parser._actions for s in a.option_strings}
    for sub in _subcommands(parser).values():
        found |= _options(sub)
    return found


def _command_lines() -> list[str]:
    """The ``tactile-synth ...`` commands of the README's bash blocks (one per line, or
    per ``&&``-joined part)."""
    lines = []
    for block in _blocks("bash"):
        for line in block.splitlines():
            for part in line.split("&&"):
                part = part.strip()
                if part.startswith("tactile-synth "):
                    lines.append(part)
    return lines


def _inline_commands() -> list[str]:
    """Inline code spans of the README that start with ``tactile-synth`` and a
    lower-case word (``tactile-synth COMMAND --help`` names no command)."""
    spans = re.findall(r"(?<!`)`([^`\n]*(?:\n[^`\n]*)?)`(?!`)", README)
    spans = [" ".join(s.split()) for s in spans]
    return [s for s in spans if re.match(r"tactile-synth [a-z]", s)]


def test_the_readme_names_commands_at_all():
    assert len(_command_lines()) >= 3
    assert len(_inline_commands()) >= 2


@pytest.mark.parametrize("line", _command_lines())
def test_every_command_of_the_bash_blocks_parses(line):
    argv = shlex.split(line)[1:]
    parser = build_parser()
    assert argv[0] in _subcommands(parser), f"{line}: no sub-command {argv[0]!r}"
    try:
        parser.parse_args(argv)
    except SystemExit as exc:  # argparse's error (2) or --help (0)
        assert exc.code == 0, f"{line}: tactile-synth refuses these arguments"


@pytest.mark.parametrize("span", _inline_commands())
def test_every_inline_command_is_a_sub_command_with_its_options(span):
    """Inline spans may name a command alone (``tactile-synth diagnose``) or leave out
    its required arguments: the sub-command and every option shown must exist."""
    words = span.split()
    commands = _subcommands(build_parser())
    assert words[1] in commands, f"{span}: no sub-command {words[1]!r}"
    known = _options(commands[words[1]]) | _options(build_parser())
    for word in words[2:]:
        if word.startswith("--"):
            assert word.split("=")[0] in known, f"{span}: no option {word}"


def _table_rows() -> list[list[str]]:
    section = README.split("## Commands", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    return [re.split(r"(?<!\\)\|", row)[1:-1] for row in rows]


def test_the_command_table_names_real_commands_and_options():
    parser = build_parser()
    commands = _subcommands(parser)
    rows = _table_rows()
    assert len(rows) >= 8
    named = set()
    for cells in rows:
        subs = []
        for span in re.findall(r"`([^`]+)`", cells[0]):
            words = span.split()
            assert words[0] in commands, f"command table: no sub-command {words[0]!r}"
            named.add(words[0])
            subs.append(commands[words[0]])
            nested = _subcommands(commands[words[0]])
            if nested and len(words) > 1:
                for name in words[1].split("\\|"):
                    assert name in nested, f"command table: no '{words[0]} {name}'"
        allowed = set().union(*(_options(s) for s in subs))
        for option in re.findall(r"(?<![\w-])--[a-z][a-z-]*", " ".join(cells[1:])):
            assert option in allowed, f"command table: {cells[0]} has no option {option}"
    # Every sub-command has its row.
    assert named == set(commands), set(commands) - named


@pytest.mark.slow
def test_the_python_block_runs_as_shown(tmp_path):
    """The README's Python block in a fresh interpreter, from an empty directory, with
    this tree first on the path (its temporary directory inside ``tmp_path``)."""
    (block,) = _blocks("python")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    env["TMPDIR"] = str(tmp_path)
    out = subprocess.run(
        [sys.executable, "-c", block],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    assert lines[0] == "(4, 2000)"  # the shape its comment states
    rows = [
        re.fullmatch(r"AFOP-ML (\d+)-way 1-shot (\d+\.\d) \+- (\d+\.\d) %", x) for x in lines[1:]
    ]
    assert rows and all(rows), lines
    ways = [int(r[1]) for r in rows]
    assert ways == sorted(ways) and set(ways) <= {5, 10, 12, 28, 36}
    assert all(0.0 <= float(r[2]) <= 100.0 for r in rows)


def test_the_docs_index_lists_every_page_and_only_pages_that_exist():
    index = README.split("## Docs", 1)[1]
    named = set(re.findall(r"`(docs/[\w-]+\.md)`", index))
    pages = {f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md")}
    assert named == pages, (pages - named, named - pages)
    # Every docs page the README names anywhere exists.
    for page in set(re.findall(r"`(docs/[\w-]+\.md)`", README)):
        assert (ROOT / page).is_file(), page


def test_the_paper_rows_are_the_papers_table_one():
    from benchmark.paper_reference import TABLE_ONE_ACCURACY_PCT

    rows = re.findall(r"^\| (\S+) \| paper \| (.*) \|$", README, flags=re.M)
    assert {method for method, _ in rows} == set(TABLE_ONE_ACCURACY_PCT)
    for method, cells in rows:
        expected = [TABLE_ONE_ACCURACY_PCT[method][(1, way)] for way in (5, 10, 12, 28, 36)]
        assert [float(c) for c in cells.split(" | ")] == expected, method
