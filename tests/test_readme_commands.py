"""Every command line quoted in the README parses against the CLI (options, types, arguments).

Command lines are the lines of ``sh`` code blocks and the inline code spans that start with
``fingerfriction`` (a span of a command's name alone only has to name a command). Usage
forms in prose (``[--reps N]``, ``lstsq|nelder-mead``) are read as the shell would run one
instance of them: brackets dropped, the first alternative taken, an upper-case placeholder
after an option (``N``, ``DIR``) given a value of the option's type.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
import typer

from fingerfriction.cli import app

README = Path(__file__).resolve().parents[1] / "README.md"


def _command_lines() -> list[str]:
    text = README.read_text(encoding="utf-8")
    lines = []
    for block in re.findall(r"```(?:sh|bash|console)\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.split(" #", 1)[0].strip()
            if line.startswith("fingerfriction"):
                lines.append(line)
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    lines += [m.strip() for m in re.findall(r"`(fingerfriction(?: [^`]*)?)`", prose)]
    return lines


def _sample(param) -> str:
    """A value of the option's type for an upper-case placeholder (``N`` -> ``1``)."""
    desc = param.type_descriptor
    if desc.is_choice:
        return str(list(desc.choices)[0])
    return {int: "1", float: "1.0"}.get(desc.annotation, "x")


def _parse(line: str) -> int:
    """Parse one command line exactly as the CLI would, without running the command; the
    exit status (0, or 2 for a usage error, whose message goes to stderr)."""
    line = line.replace("[", " ").replace("]", " ")
    words = [w.split("|")[0] if "|" in w and not w.startswith("-") else w for w in shlex.split(line)][1:]
    group = typer.main.get_command(app)
    if len(words) == 1 and not words[0].startswith("-"):  # a command named in prose
        return 0 if words[0] in group.commands else 2
    name = next((w for w in words if w in group.commands), None)
    if name is not None:
        cmd = group.commands[name]
        opts = {o: p for p in cmd.params for o in (*p.opts, *p.secondary_opts)}
        words = [_sample(opts[words[i - 1]]) if i and words[i - 1] in opts and not opts[words[i - 1]].is_flag
                 and re.fullmatch(r"[A-Z][A-Z0-9_]*", w) else w for i, w in enumerate(words)]
        cmd.callback = lambda *a, **k: None  # parse and convert every option, run nothing
    try:
        group.main(words, prog_name="fingerfriction", standalone_mode=True)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


LINES = _command_lines()


def test_the_readme_quotes_commands():
    assert len(LINES) > 20
    assert any(line.startswith("fingerfriction init") for line in LINES)


@pytest.mark.parametrize("line", LINES)
def test_readme_command_parses(line, capsys):
    status = _parse(line)
    err = capsys.readouterr().err
    assert status == 0, f"README command does not parse: {line!r}: {err}"


def test_the_check_catches_a_wrong_option(capsys):
    assert _parse("fingerfriction analyze STUDY --out RESULTS --no-such-option") == 2
    assert "No such option" in capsys.readouterr().err
    assert _parse("fingerfriction fit RESULTS --mu-min N") == 0  # a placeholder gets a number
