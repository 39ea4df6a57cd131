"""The CLI entry point exists and answers --help."""

from typer.testing import CliRunner

from demcal.cli import app


def test_help_lists_commands():
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "Calibrate DEM material parameters" in result.output


def test_usage_errors_are_one_line_and_exit_2():
    """Through the console script (not CliRunner): click's usage errors are one line."""
    import subprocess
    import sys

    for args, needle in ((["calibrate", "x.toml", "--workers", "0"], "'--workers'"),
                         (["frobnicate"], "No such command"),
                         (["simulate", "aor", "--bogus", "1"], "No such option: --bogus"),
                         (["calibrate"], "Missing argument")):
        res = subprocess.run([sys.executable, "-m", "demcal", *args], capture_output=True,
                             text=True, timeout=120)
        assert res.returncode == 2, res.stderr
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], lines
    res = subprocess.run([sys.executable, "-m", "demcal"], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0 and res.stdout.count("Usage") == 1
