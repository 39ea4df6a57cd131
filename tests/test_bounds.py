"""Every count, size, seed and number has a bound: beyond it, exit 2 and one line, at once."""

from __future__ import annotations

import shutil
import struct
import time
import zlib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.cli import app
from demcal.errors import InputError
from demcal.execute.dask_exec import check_address

# distributed's scheduler serves its HTTP routes on port 8787 even with no dashboard; when a
# parallel test (pytest -n) or another suite on the host holds it, it moves and warns, and
# warnings are errors here: a free port of the OS's choosing instead
FREE_PORT = "127.0.0.1:0"

ROOT = Path(__file__).resolve().parents[1]
ANALYTIC = ROOT / "examples" / "analytic" / "study.toml"
CORN = ROOT / "examples" / "corn_stalk"


def _one_line_refusal(args: list[str], *, within_s: float = 20.0) -> str:
    t0 = time.perf_counter()
    res = CliRunner().invoke(app, args)
    assert time.perf_counter() - t0 < within_s
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), res.output
    return lines[0]


def _study(tmp_path: Path, old: str, new: str) -> str:
    text = ANALYTIC.read_text()
    assert old in text
    path = tmp_path / "study.toml"
    path.write_text(text.replace(old, new, 1))
    return str(path)


@pytest.mark.parametrize("args, words", [
    (["simulate", "aor", "--test", "fill.count=1000000000"], "at most 200,000"),
    (["simulate", "aor", "--fidelity", "paper", "--test", "fill.rate=1e12"],
     "particles per run"),
    (["simulate", "aor", "--seeds", "1000"], "--seeds must be in 1..256"),
    (["simulate", "aor", "--test", "fill=1", "--test", "fill.count=2"],
     "--test: 'fill.count' sets a key of 'fill', which is a value"),
    (["simulate", "aor", "--seed", "-1"], "--seed must be in"),
    (["simulate", "aor", "--seed", str(2**63 - 1)], "--seed must be in"),
    (["design", "lhs", "--factors", str(CORN / "factors_pb.toml"), "--runs", "1000000000"],
     "--runs must be in"),
    (["design", "pb", "--factors", str(CORN / "factors_pb.toml"), "--seed", "-1"],
     "--seed must be in"),
    (["design", "steepest", "--factors", str(CORN / "factors_pb.toml"), "--coef",
      "x3=nan,x4=1"], "finite"),
    (["optimize", str(CORN / "table7_bbd.csv"), "--response", "aor_deg", "--target", "44",
      "--fix", "x3=nan"], "finite"),
    (["optimize", str(CORN / "table7_bbd.csv"), "--response", "aor_deg", "--target", "nan"],
     "--target"),
])
def test_cli_bounds(args, words):
    assert words in _one_line_refusal(args)


@pytest.mark.parametrize("old, new, words", [
    ("seed = 1", f"seed = {2**63 - 1}", "seed"),
    ("seed = 1", "seed = -1", "seed"),
    ("base_deg = 30.0", "base_deg = nan", "base_deg"),
    ("low = 0.2\nhigh = 0.6", "low = -1e308\nhigh = 1e308", "factors.0"),
    ("[executor]\nworkers = 1", '[executor]\nworkers = 1\ndask = "tcp://localhost"', "port"),
    ("[executor]\nworkers = 1", "[executor]\nworkers = 1\nchunk = 1000000000", "chunk"),
    ('kind = "analytic"', 'kind = "aor"\noverrides = { fill = { count = 1000000000 } }',
     "particles per run"),
])
def test_study_bounds(tmp_path, old, new, words):
    path = _study(tmp_path, old, new)
    assert words in _one_line_refusal(["calibrate", path, "--external", "--no-report"])
    assert not (tmp_path / "demcal.sqlite").exists()


def test_dask_address_without_port_on_the_command_line(tmp_path):
    shutil.copy(ANALYTIC, tmp_path / "study.toml")
    line = _one_line_refusal(["calibrate", str(tmp_path / "study.toml"), "--dask",
                              "tcp://localhost"])
    assert "needs a host and a port" in line
    assert not (tmp_path / "demcal.sqlite").exists()


def test_check_address():
    assert check_address("scheduler:8786") == "tcp://scheduler:8786"
    assert check_address("tls://10.0.0.1:8786") == "tls://10.0.0.1:8786"
    for bad in ("localhost", "tcp://:8786", "tcp://h:0", "tcp://h:99999", "ftp://h:1"):
        with pytest.raises(InputError):
            check_address(bad)


def test_huge_template_sphere_count(tmp_path):
    text = (CORN / "measurements.toml").read_text().replace("n_spheres = 7",
                                                            "n_spheres = 100000000")
    (tmp_path / "m.toml").write_text(text)
    assert "n_spheres" in _one_line_refusal(["physical", str(tmp_path / "m.toml")],
                                            within_s=10)


def _bomb(path: Path, side: int = 60_000) -> None:
    """A 3 kB PNG that claims side x side pixels (3.6 gigapixels)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    co = zlib.compressobj(9)
    data = b"".join(co.compress(b"\x00" * (side + 1)) for _ in range(20)) + co.flush()
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", side, side,
                                                                         8, 0, 0, 0, 0))
                     + chunk(b"IDAT", data) + chunk(b"IEND", b""))


def test_decompression_bomb_photo(tmp_path):
    _bomb(tmp_path / "bomb.png")
    assert "decompression bomb" in _one_line_refusal(["measure", str(tmp_path / "bomb.png")])
    path = _study(tmp_path, "aor_deg = 40.0\nstd_deg = 1.0\nn = 5", 'photos = ["bomb.png"]')
    assert "decompression bomb" in _one_line_refusal(["calibrate", path, "--no-report"])


def test_dask_without_workers_says_so_and_times_out(caplog):
    distributed = pytest.importorskip("distributed")
    from demcal.errors import StudyError
    from demcal.execute.dask_exec import run_dask
    from demcal.execute.tasks import RunTask, TestDef

    task = RunTask("k", TestDef(kind="analytic", analytic={}), {}, 1, 1.0, None)
    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=FREE_PORT) as cluster:
        t0 = time.monotonic()
        with pytest.raises(StudyError, match=r"no Dask worker connected.*timeout 1 s"):
            run_dask([[task]], lambda r: None, address=cluster.scheduler_address,
                     idle_timeout=1.0, poll_s=0.2)
        assert time.monotonic() - t0 < 20
    assert "no Dask worker connected" in caplog.text


@pytest.mark.parametrize("old, new, words", [
    ("std_deg = 1.0", "std_deg = inf", "std_deg"),
    ("n = 5", "n = 10000000000", "target.n"),
    ('factors = ["x8"]', 'factors = ["x8"]\nhard_limits = { x8 = [0.0, inf] }', "hard_limits"),
    ("[stages.steepest]\nsteps = 5", "[stages.steepest]\nsteps = 5\nstep = nan", "step"),
    ("[material]", '[material]\noverrides = { "particle.density" = inf }', "overrides"),
])
def test_study_numbers_are_finite_and_bounded(tmp_path, old, new, words):
    path = _study(tmp_path, old, new)
    line = _one_line_refusal(["calibrate", path, "--external", "--no-report"])
    assert words in line
