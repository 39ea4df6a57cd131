"""Issue 38, class 5: no accepted input hangs. A named pipe (or a device) given as an input
file is refused before it is opened; a parameter that would make the engine's time step
vanish (``particle.density = 1e-300``) is refused before the first step."""

from __future__ import annotations

import os
import sys
import time

import pytest
from typer.testing import CliRunner

from demcal.cli import app

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX named pipes")


@pytest.fixture
def fifo(tmp_path):
    path = tmp_path / "pipe.png"
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("args", [
    ["measure", "{f}"],
    ["physical", "{f}"],
    ["analyze", "{f}", "--response", "aor_deg"],
    ["design", "bbd", "--factors", "{f}"],
])
def test_a_named_pipe_is_refused_not_read(fifo, args):
    t0 = time.monotonic()
    res = CliRunner().invoke(app, [a.format(f=fifo) for a in args])
    assert time.monotonic() - t0 < 30
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "named pipe (FIFO), not a regular file" in lines[0], lines


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/dev/zero")
def test_a_device_is_refused_as_a_photo():
    res = CliRunner().invoke(app, ["measure", "/dev/zero"])
    assert res.exit_code == 2 and "a device, not a regular file" in res.output, res.output


def test_a_vanishing_time_step_is_refused_before_the_first_step():
    from demcal.errors import InputError
    from demcal.virtual import fidelity_config, preset_parameters, run_aor

    params = preset_parameters("corn_stalk", {"particle.density": 1e-300})
    config = fidelity_config("quick", **{"fill": {"count": 20}})
    t0 = time.monotonic()
    with pytest.raises(InputError, match=r"time step would be .* below 1e-09 s"):
        run_aor([params], config=config, seeds=[0])
    assert time.monotonic() - t0 < 120


def test_a_photo_whose_measurement_would_not_fit_in_memory_is_refused(tmp_path,
                                                                       monkeypatch):
    from PIL import Image

    import demcal.safety as safety

    photo = tmp_path / "pile.png"
    Image.new("L", (400, 300), 200).save(photo)  # 0.12 MP: about 17 MB to measure
    monkeypatch.setattr(safety, "available_memory", lambda: 8 * 2**20)
    res = CliRunner().invoke(app, ["measure", str(photo)])
    assert res.exit_code == 2, res.output
    assert "megapixels need about" in res.output and "GiB is available" in res.output
    monkeypatch.setattr(safety, "available_memory", lambda: 64 * 2**20)
    assert safety.photo_too_large(photo) is None
