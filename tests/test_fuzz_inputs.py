"""Fuzz: a mangled study file or run sheet gives exit 2 and one line, never a traceback."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import pandas as pd
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from demcal.cli import app
from demcal.store import RunStore

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "analytic" / "study.toml"
LINES = EXAMPLE.read_text().splitlines()
VALUE_LINES = [i for i, line in enumerate(LINES) if " = " in line and not line.startswith("#")]
WEIRD = ["nan", "inf", "-inf", "1e308", "-1e308", "9223372036854775807", "-1", "0", "1e-320",
         '"[/]"', '"[bold]x[/bold]"', "[]", "{}", '"=cmd|x"', "true", '"../../etc/passwd"',
         '"\\u0000"', "[1e308, -1e308]", '"tcp://host"', "18446744073709551616", '""', "3.5"]
FUZZ = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])


def _check(res) -> None:
    assert res.exception is None or isinstance(res.exception, SystemExit), \
        f"traceback: {res.exception!r}\n{res.output}"
    assert res.exit_code in (0, 2), res.output
    if res.exit_code == 2:
        lines = res.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error:"), res.output


@st.composite
def mangled_study(draw) -> bytes:
    lines = list(LINES)
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.sampled_from(VALUE_LINES))
        key = lines[i].split(" = ")[0]
        value = draw(st.one_of(st.sampled_from(WEIRD), st.text(max_size=12).map(repr)))
        lines[i] = f"{key} = {value}"
    text = "\n".join(lines).encode()
    kind = draw(st.sampled_from(["values", "truncate", "bytes"]))
    if kind == "truncate":
        text = text[:draw(st.integers(0, len(text)))]
    elif kind == "bytes":
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.binary(min_size=1, max_size=8)) + text[at:]
    return text


@FUZZ
@given(mangled_study())
def test_fuzz_study_file(content):
    with tempfile.TemporaryDirectory() as tmp:
        study = Path(tmp) / "study.toml"
        study.write_bytes(content)
        res = CliRunner().invoke(app, ["calibrate", str(study), "--external", "--no-report"])
        _check(res)


_SHEET: dict[str, Path] = {}


def _sheet() -> tuple[Path, Path, str]:
    """A study folder with its rangefind run sheet (made once, copied per example)."""
    if "dir" not in _SHEET:
        tmp = Path(tempfile.mkdtemp(prefix="demcal-fuzz-"))
        shutil.copy(EXAMPLE, tmp / "study.toml")
        res = CliRunner().invoke(app, ["calibrate", str(tmp / "study.toml"), "--external",
                                       "--no-report"])
        assert res.exit_code == 0, res.output
        _SHEET["dir"] = tmp
    tmp = _SHEET["dir"]
    return tmp / "study.toml", tmp / "runsheet_rangefind.csv", \
        (tmp / "runsheet_rangefind.csv").read_text()


CELLS = ["", "nan", "inf", "-1", "1e308", "45", "0", "90", "pile", "column", "=cmd|' /C calc'!A0",
         "[/]", "x", "9223372036854775808", "1.5", "unstable"]


@FUZZ
@given(st.data())
def test_fuzz_import_sheet(data):
    study, sheet, text = _sheet()
    frame = pd.read_csv(sheet, dtype=str, keep_default_na=False)
    kind = data.draw(st.sampled_from(["cells", "rows", "bytes", "truncate"]))
    if kind == "cells":  # some cells of the real sheet replaced by odd values
        for _ in range(data.draw(st.integers(1, 4))):
            r = data.draw(st.integers(0, len(frame) - 1))
            c = data.draw(st.sampled_from(list(frame.columns)))
            frame.loc[r, c] = data.draw(st.sampled_from(CELLS))
        frame["aor_deg"] = frame["aor_deg"].replace("", "40")
        content = frame.to_csv(index=False).encode()
    elif kind == "rows":  # real rows, repeated or dropped, with responses
        idx = data.draw(st.lists(st.integers(0, len(frame) - 1), max_size=8))
        part = frame.iloc[idx].copy()
        part["aor_deg"] = "41.5"
        content = part.to_csv(index=False).encode()
    elif kind == "bytes":
        content = data.draw(st.binary(max_size=200))
    else:
        content = text.encode()[:data.draw(st.integers(0, len(text)))]
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        shutil.copy(study, work / "study.toml")
        store = study.parent / "demcal.sqlite"
        shutil.copy(store, work / "demcal.sqlite")
        path = work / "sheet.csv"
        path.write_bytes(content)
        res = CliRunner().invoke(app, ["import", str(path), "--study", str(work / "study.toml")])
        _check(res)
        if res.exit_code == 2:  # all or nothing
            with RunStore(work, readonly=True) as s:
                assert s.count() == 0
