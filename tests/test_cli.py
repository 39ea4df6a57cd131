"""The CLI entry point exists and answers --help."""

import sys

import pytest
from typer.testing import CliRunner

from demcal.cli import app, main


def test_help_lists_commands():
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "Calibrate DEM material parameters" in result.output


def test_the_console_script_answers_a_usage_error_in_one_line():
    """Through ``python -m demcal`` (not CliRunner): the real entry point, in a process."""
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "demcal", "frobnicate"], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0] == "error: No such command 'frobnicate'. (see " \
        "`python -m demcal --help`)", lines


@pytest.mark.parametrize(("args", "needle"), [
    (["calibrate", "x.toml", "--workers", "0"], "'--workers'"),
    (["frobnicate"], "No such command"),
    (["simulate", "aor", "--bogus", "1"], "No such option: --bogus"),
    (["calibrate"], "Missing argument")])
def test_usage_errors_are_one_line_and_exit_2(args, needle, monkeypatch, capsys):
    """main(), the console script's entry, in this process (one subprocess above shows the
    script reaches it; a process per case cost ~5-10 s of imports each): click's usage
    errors are one line on stderr and exit code 2."""
    monkeypatch.setattr(sys, "argv", ["demcal", *args])
    with pytest.raises(SystemExit) as exit_:
        main()
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], lines


def test_no_arguments_print_the_help_once(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["demcal"])
    with pytest.raises(SystemExit) as exit_:
        main()
    assert exit_.value.code == 0 and capsys.readouterr().out.count("Usage") == 1


def _commands(group, path=()):
    """Every command of the click tree under ``group``, with its path of names."""
    for name, cmd in getattr(group, "commands", {}).items():
        yield (*path, name), cmd
        yield from _commands(cmd, (*path, name))


def test_square_brackets_in_help_text_are_printed():
    """The help is rich markup: an unescaped ``[factors.NAME]``, ``[[responses]]`` or
    ``demcal[lammps]`` was swallowed as a tag ("Factors TOML file ( low/high)")."""
    import re

    import typer

    root = typer.main.get_command(app)
    checked = 0
    for path, cmd in _commands(root):
        texts = [p.help for p in cmd.params if getattr(p, "help", None)] + [cmd.help or ""]
        wanted = {t for text in texts for t in re.findall(r"\[[^\]\s]+\]+",
                                                           text.replace("\\[", "["))}
        if not wanted:
            continue
        out = CliRunner().invoke(app, [*path, "--help"], terminal_width=400).output
        flat = " ".join(out.replace("│", " ").split())
        for token in wanted:
            assert token in flat, (path, token)
            checked += 1
    assert checked >= 4
