"""The CLI entry point exists and answers --help."""

from typer.testing import CliRunner

from demcal.cli import app


def test_help_lists_commands():
    result = CliRunner().invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "Calibrate DEM material parameters" in result.output
