"""Issue 38, class 2: a standard output that goes away (``| head``, a hung-up terminal)
costs no result: the command runs to its end, writes its files, then exits with 141 and one
line on stderr."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import typer

from demcal.cli._common import cli_errors, console
from demcal.cli._stdout import EXIT_STDOUT_GONE, reset, stdout_gone

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "analytic" / "study.toml"


@pytest.fixture(autouse=True)
def _console_back():
    """Each test's gone stdout is forgotten after it (a command does so when it starts)."""
    yield
    reset()


class _GoneStdout:
    """A stdout whose reader went away: every write fails like a closed pipe (or a
    hung-up terminal, with ``code=errno.EIO``)."""

    def __init__(self, code: int = errno.EPIPE) -> None:
        self.code = code

    def write(self, text: str) -> int:
        raise OSError(self.code, os.strerror(self.code))

    def flush(self) -> None:
        raise OSError(self.code, os.strerror(self.code))

    def isatty(self) -> bool:
        return False


@pytest.mark.parametrize("code", [errno.EPIPE, errno.EIO])
def test_a_gone_stdout_costs_no_file_and_exits_141(tmp_path, monkeypatch, code):
    out = tmp_path / "result.json"

    @cli_errors
    def command() -> None:
        console.print("first line")  # the console is gone already
        out.write_text(json.dumps({"done": True}))  # ... the work goes on
        console.print("wrote it")

    monkeypatch.setattr(sys, "stdout", _GoneStdout(code))
    with pytest.raises(typer.Exit) as done:
        command()
    assert done.value.exit_code == EXIT_STDOUT_GONE
    assert json.loads(out.read_text()) == {"done": True}
    assert stdout_gone()


def test_calibrate_into_a_closed_pipe_writes_its_json_and_card(tmp_path):
    study = tmp_path / "study.toml"
    shutil.copy(EXAMPLE, study)
    proc = subprocess.Popen([sys.executable, "-m", "demcal", "calibrate", str(study),
                             "--json", str(tmp_path / "res.json"), "--no-report"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path)
    proc.stdout.close()  # the reader is gone before the first line: `| head -c 0`
    with proc.stderr:
        err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == EXIT_STDOUT_GONE, err
    assert err.strip().splitlines() == [
        "failed: standard output was closed (a closed pipe or a hung-up terminal); the "
        "command ran to its end and wrote its files, but not all of its output was shown"]
    assert json.loads((tmp_path / "res.json").read_text())["optimum"]
    assert (tmp_path / "report" / "material.toml").is_file()


def test_physical_into_a_gone_stdout_writes_its_json(tmp_path, monkeypatch):
    from demcal.cli.physical_cmd import physical

    out = tmp_path / "derived.json"
    measurements = Path(__file__).resolve().parents[1] / "examples" / "corn_stalk" / \
        "measurements.toml"
    monkeypatch.setattr(sys, "stdout", _GoneStdout())
    with pytest.raises(typer.Exit) as done:
        physical(measurements=measurements, json_out=out, range_rule=None, k=None,
                 ci_level=None)
    assert done.value.exit_code == EXIT_STDOUT_GONE
    assert json.loads(out.read_text())


def test_a_hung_up_terminal_does_not_end_a_study(tmp_path):
    import signal
    import time

    study = tmp_path / "study.toml"
    study.write_text(EXAMPLE.read_text().replace("noise_deg = 0.3",
                                                 "noise_deg = 0.3\ndelay_s = 0.05", 1))
    proc = subprocess.Popen([sys.executable, "-m", "demcal", "calibrate", str(study),
                             "--json", str(tmp_path / "res.json"), "--no-report",
                             "--workers", "1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
    deadline = time.monotonic() + 120
    while not (tmp_path / "demcal.sqlite").exists():  # the study is running
        assert time.monotonic() < deadline and proc.poll() is None
        time.sleep(0.1)
    time.sleep(0.5)
    proc.send_signal(signal.SIGHUP)  # the terminal hung up: the study goes on
    assert proc.wait(timeout=300) == 0
    assert json.loads((tmp_path / "res.json").read_text())["optimum"]


def test_a_progress_display_on_a_terminal_prints_through_the_guard(monkeypatch):
    """rich's live display replaces sys.stdout by a proxy printing through the console: the
    guard writes under that proxy, not into it (which looped for ever on a terminal)."""
    import io

    from rich.progress import Progress

    class _Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    import threading

    term = _Terminal()
    monkeypatch.setattr(sys, "stdout", term)

    def show() -> None:
        with Progress(console=console, auto_refresh=False) as progress:
            task = progress.add_task("stage", total=2)
            print("a line printed meanwhile")  # goes through rich's proxy of sys.stdout
            progress.update(task, advance=2, refresh=True)

    shown = threading.Thread(target=show, daemon=True)  # the loop hung: fail, not hang
    shown.start()
    shown.join(timeout=30)
    assert not shown.is_alive(), "printing under a live display loops"
    assert "a line printed meanwhile" in term.getvalue() and "stage" in term.getvalue()
