"""The drum's runs as worlds of one engine: each world's result is its run alone, bit for bit,
and a world that ends early (here: a fill that does not settle) ends alone while the others go
on, its result handed over the moment it ends."""

from __future__ import annotations

import re

import pytest

from demcal.execute.tasks import RunTask, TestDef, run_chunk
from demcal.virtual.drum import DrumReporting, run_drum
from demcal.virtual.drum_settings import drum_settings
from demcal.virtual.presets import preset_parameters

#: the cheapest drum that still goes through every phase: 20 stalks, 3 frames, a 2-frame
#: steady window, twice the default time step; the lining (wall friction 0.9) carries the
#: bed so that it rolls and is measured (~1 s per run on one core)
TINY = {"drum": {"count": 20, "frames": 3, "steady_window": 2, "spin_up_s": 0.04,
                 "settle_max_s": 0.3, "wall_static_friction": 0.9}, "dt_fraction": 0.4}
#: a bouncing, frictionless fill: it does not settle within TINY's 0.3 s (``unsettled``)
BOUNCY = {"pp.restitution": 0.95, "pw.restitution": 0.95, "pp.static_friction": 0.05,
          "pw.static_friction": 0.05, "pp.rolling_friction": 0.0, "pw.rolling_friction": 0.0}


def _same(batched, alone) -> None:
    """Every field but the wall time equal: the angles, the frames, the outcome and reason,
    the simulated times."""
    a, b = batched.to_dict(), alone.to_dict()
    assert {k: v for k, v in a.items() if k != "wall_time_s"} == \
        {k: v for k, v in b.items() if k != "wall_time_s"}


def test_a_world_that_ends_early_ends_alone_and_the_batch_equals_its_runs_alone(tmp_path):
    """World 1's fill keeps bouncing: it ends ``unsettled`` at 0.3 s, is handed over first
    and paused, while world 0 turns on to its frames; both equal their runs alone (their
    time steps differ: each world steps with its own)."""
    settings = drum_settings("quick", TINY)
    sets = [preset_parameters("corn_stalk_dry"), preset_parameters("corn_stalk_dry", BOUNCY)]
    ended, phases = [], []
    batch = run_drum(sets, settings=settings, seeds=[1, 5], backend="cpu",
                     reporting=DrumReporting(
                         on_result=lambda i, r: ended.append((i, r.outcome)),
                         progress=lambda i, phase, t, wall: phases.append((i, phase)),
                         vtk_dir=tmp_path / "vtk"))
    assert ended == [(1, "unsettled"), (0, batch[0].outcome)]
    assert batch[0].outcome == "rolling" and batch[0].dynamic_aor_deg is not None
    assert len(batch[0].frames_deg) == 3 and batch[0].sim_time_s > batch[1].sim_time_s
    assert "did not settle within 0.3 s" in batch[1].reason and batch[1].frames_deg == []
    assert batch[0].time_step_s != batch[1].time_step_s
    # progress per run: the ended one stops reporting, the other goes through every phase
    assert {p for i, p in phases if i == 1} == {"settle"}
    assert [p for i, p in phases if i == 0][-4:] == ["steady", "frames", "frames", "frames"]
    # a VTK series per world: the ended one's bed is never written after it ended
    for seed, beds in ((1, ["settled", "spun_up", "steady"] + ["frame"] * 3), (5, [])):
        pvd = tmp_path / "vtk" / f"drum_seed{seed}.pvd"
        labels = re.findall(r'_\d{4}_([a-z_]+?)(_walls)?\.vtp"', pvd.read_text()) if beds else []
        labels = [name for name, walls in labels if not walls]
        assert labels == beds
        assert pvd.exists() == bool(beds)
    for params, seed, batched in zip(sets, (1, 5), batch, strict=True):
        (alone,) = run_drum([params], settings=settings, seeds=[seed], backend="cpu")
        _same(batched, alone)


def test_an_unstable_world_stops_at_its_frame_alone_and_the_other_goes_on(monkeypatch):
    """With the overlap limit lowered to 5 % of a radius, a soft material (shear modulus
    1e5 Pa) overlaps past it while the fill settles and goes ``unstable``; the stiff world
    beside it rolls on to its frames. The soft one is its run alone (the first test shows
    that a world that finishes is); only the time at which the engine's health check caught
    it may differ (here it does not): the checks fall after every engine call and every
    ``CHUNK_STEPS`` steps, and the stiff world's points add calls."""
    from demcal.dem import _config

    monkeypatch.setattr(_config, "MAX_OVERLAP_FRACTION", 0.05)
    settings = drum_settings("quick", TINY)
    sets = [preset_parameters("corn_stalk_dry"),
            preset_parameters("corn_stalk_dry", {"particle.shear_modulus": 1e5})]
    ended: list[int] = []
    batch = run_drum(sets, settings=settings, seeds=[1, 1], backend="cpu",
                     reporting=DrumReporting(on_result=lambda i, r: ended.append(i)))
    assert ended == [1, 0]
    stiff, soft = batch
    assert stiff.outcome == "rolling" and len(stiff.frames_deg) == 3
    assert soft.outcome == "unstable" and soft.reason.startswith("a contact overlap exceeded 5%")
    (alone,) = run_drum(sets[1:], settings=settings, seeds=[1], backend="cpu")
    when = re.compile(r" \(at t=[0-9.e-]+ s\)$")
    assert when.sub("", soft.reason) == when.sub("", alone.reason)
    assert abs(soft.sim_time_s - alone.sim_time_s) < _config.CHUNK_STEPS * soft.time_step_s
    a, b = soft.to_dict(), alone.to_dict()
    assert {k: v for k, v in a.items() if k not in ("wall_time_s", "reason", "sim_time_s")} \
        == {k: v for k, v in b.items() if k not in ("wall_time_s", "reason", "sim_time_s")}


def test_a_repeated_seed_gets_its_own_vtk_series(tmp_path):
    """Two runs of one seed in a call write two series, not one file set twice."""
    from demcal.virtual.drum import _series_names

    assert _series_names([4, 5]) == ["drum_seed4", "drum_seed5"]
    assert _series_names([4, 4]) == ["drum_run000_seed4", "drum_run001_seed4"]


def test_a_study_chunk_hands_each_drum_run_over_as_it_ends():
    """``run_chunk`` runs a chunk of drum tasks as one batch per time-step scale: the run
    that ends first is emitted first, and a retried run (scale 0.5) runs in its own engine at
    half the step."""
    test = TestDef(kind="drum", fidelity="quick", overrides=TINY, backend="cpu")
    dry, bouncy = preset_parameters("corn_stalk_dry"), preset_parameters("corn_stalk_dry",
                                                                         BOUNCY)
    tasks = [RunTask("a", test, dry, 1), RunTask("b", test, bouncy, 5),
             RunTask("c", test, bouncy, 5, dt_scale=0.5)]
    seen: list[str] = []
    out = run_chunk(tasks, on_result=lambda r: seen.append(r.key))
    # the scale-0.5 engine runs first (sorted scales), then the batch of a and b
    assert seen == ["c", "b", "a"] == [r.key for r in out]
    by_key = {r.key: r for r in out}
    assert by_key["a"].outcome == "rolling" and by_key["b"].outcome == "unsettled"
    assert by_key["c"].detail["time_step_s"] == pytest.approx(
        0.5 * by_key["b"].detail["time_step_s"])


@pytest.mark.slow
def test_three_worlds_of_different_materials_and_steps_equal_their_runs_alone():
    """The quick drum's particle count and time step: a cohesive world (the engine's contact
    margin is the batch's largest, so the dry worlds' pairs are looked at farther out), a
    light one and one of a denser material (another time step) give, batched, each its
    result alone (~40 s on one core)."""
    settings = drum_settings("quick", {"drum": {"frames": 4, "steady_window": 2,
                                                "wall_static_friction": 0.9}})
    sets = [preset_parameters("corn_stalk_dry"),
            preset_parameters("corn_stalk_dry", {"pp.static_friction": 0.3,
                                                 "particle.density": 300.0}),
            preset_parameters("corn_stalk")]
    seeds = [1, 2, 4]
    batch = run_drum(sets, settings=settings, seeds=seeds, backend="cpu")
    assert len({r.time_step_s for r in batch}) == 3
    for params, seed, batched in zip(sets, seeds, batch, strict=True):
        (alone,) = run_drum([params], settings=settings, seeds=[seed], backend="cpu")
        _same(batched, alone)
