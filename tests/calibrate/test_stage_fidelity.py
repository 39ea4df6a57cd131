"""A study whose screening and steepest path run at a lower fidelity than its response surface
and verification; and the local pool's chunks sized so that no worker waits."""

from __future__ import annotations

import dataclasses
import tomllib

import pytest

import demcal.execute.tasks as tasks
from demcal.calibrate import calibrate
from demcal.calibrate.runner import Point, Runner, RunnerOptions
from demcal.calibrate.study import parse_study
from demcal.errors import InputError
from demcal.execute.tasks import TestDef
from demcal.store import RunStore
from demcal.virtual import preset_parameters

REAL_RUN_CHUNK = tasks.run_chunk


class StandIn:
    """Runs every task on the analytic stand-in, remembering which fidelity each stage asked
    for (the engine's test is what is routed; the stand-in gives it fast answers)."""

    def __init__(self, analytic: dict):
        self.test = TestDef(kind="analytic", analytic=analytic)
        self.asked: dict[str, set[str]] = {}
        self.chunk_sizes: list[int] = []

    def __call__(self, chunk, on_result=None):
        self.chunk_sizes.append(len(chunk))
        for t in chunk:
            self.asked.setdefault(t.key.partition(":")[0], set()).add(t.test.fidelity)
        return REAL_RUN_CHUNK([dataclasses.replace(t, test=self.test) for t in chunk], on_result)


@pytest.fixture
def two_fidelity_study(study_file, example_data):
    """The analytic example as a study of the engine's standard test whose screening and
    steepest path run at the small one, its range finding at the quick one."""
    text = study_file.read_text()
    for old, new in (('kind = "analytic"', 'kind = "aor"\nfidelity = "standard"'),
                     ("[stages.rangefind]\n", '[stages.rangefind]\nfidelity = "quick"\n'),
                     ("[stages.screening]\n", '[stages.screening]\nfidelity = "small"\n'),
                     ("[stages.steepest]\n", '[stages.steepest]\nfidelity = "small"\n')):
        assert old in text
        text = text.replace(old, new)
    study_file.write_text(text)
    return study_file, example_data["test"]["analytic"]


def test_screening_and_path_run_at_their_fidelity_the_surface_at_the_study_s(
        two_fidelity_study, monkeypatch):
    path, analytic = two_fidelity_study
    stand_in = StandIn(analytic)
    monkeypatch.setattr(tasks, "run_chunk", stand_in)
    res = calibrate(path)
    assert stand_in.asked == {"rangefind": {"quick"}, "screening": {"small"},
                              "steepest": {"small"}, "steepest_anchor": {"standard"},
                              "rsm": {"standard"}, "verification": {"standard"}}
    assert res["stages"]["screening"].get("fidelity") == "small"
    with RunStore(path.parent) as store:
        assert store.stage("screening").summary["fidelity"] == "small"
        assert "fidelity" not in store.stage("rsm").summary
    # resumed, nothing runs again: the stages' own tests are part of their run keys
    again = StandIn(analytic)
    monkeypatch.setattr(tasks, "run_chunk", again)
    assert calibrate(path)["optimum"] == res["optimum"]
    assert again.asked == {}


def _surface_at(path, fid):
    """The study at ``path`` with its response surface fitted on the ``fid`` test."""
    text = path.read_text()
    assert "[stages.rsm]\n" in text
    path.write_text(text.replace("[stages.rsm]\n", f'[stages.rsm]\nfidelity = "{fid}"\n'))


def test_a_surface_on_the_small_test_verified_on_the_study_s(two_fidelity_study, monkeypatch):
    """stages.rsm.fidelity: the design runs the small test, the verification the study's
    (standard); the path at the surface's fidelity needs no anchor; the verification is not
    sized with the other test's pure error; the result, the store and the report say which
    test the surface is on."""
    from demcal.report import build_report

    path, analytic = two_fidelity_study
    _surface_at(path, "small")
    stand_in = StandIn(analytic)
    monkeypatch.setattr(tasks, "run_chunk", stand_in)
    res = calibrate(path)
    assert stand_in.asked == {"rangefind": {"quick"}, "screening": {"small"},
                              "steepest": {"small"}, "rsm": {"small"},
                              "verification": {"standard"}}
    assert res["stages"]["rsm"]["fidelity"] == "small"
    with RunStore(path.parent) as store:
        assert store.stage("rsm").summary["fidelity"] == "small"
        assert "sized_with_std" not in store.stage("verification").summary
    html = build_report(path.parent, out_dir=path.parent / "report").read_text()
    assert "on the small test (the verification runs the study&#x27;s)" in html
    again = StandIn(analytic)
    monkeypatch.setattr(tasks, "run_chunk", again)
    assert calibrate(path)["optimum"] == res["optimum"]
    assert again.asked == {}


def test_a_path_cheaper_than_the_surface_is_anchored_at_the_surface_s_test(
        two_fidelity_study, monkeypatch):
    """Path at 'quick', surface at 'small' in a 'standard' study: the anchor runs the test
    the surface is fitted on, not the study's."""
    path, analytic = two_fidelity_study
    _surface_at(path, "small")
    path.write_text(path.read_text().replace(
        '[stages.steepest]\nfidelity = "small"\n', '[stages.steepest]\nfidelity = "quick"\n'))
    stand_in = StandIn(analytic)
    monkeypatch.setattr(tasks, "run_chunk", stand_in)
    res = calibrate(path)
    assert stand_in.asked["steepest_anchor"] == {"small"}
    assert stand_in.asked["rsm"] == {"small"}
    assert stand_in.asked["verification"] == {"standard"}
    anchor = res["stages"]["steepest"]["anchor"]
    assert anchor["fidelity"] == "small"
    assert anchor["message"].startswith("the surface's test (small)")


def test_a_stage_fidelity_changes_that_stage_s_run_keys_only(two_fidelity_study):
    path, _ = two_fidelity_study
    study = parse_study(tomllib.loads(path.read_text()))
    base = TestDef(kind="aor", fidelity="standard")
    runner = Runner(None, base, RunnerOptions(stage_tests={"screening": dataclasses.replace(
        base, fidelity=study.stages.screening.fidelity)}))
    p = Point(point=0, replicate=0, params={"pp.static_friction": 0.5}, seed=1)
    plain = Runner(None, base)
    assert runner.key("rsm", p) == plain.key("rsm", p)
    assert runner.key("screening", p) != plain.key("screening", p)
    assert runner.test_for("screening").fidelity == "small"


def test_a_stage_fidelity_needs_the_engine_s_test(example_data):
    data = dict(example_data)
    data["stages"] = {**data["stages"], "screening": {"fidelity": "small"}}
    with pytest.raises(InputError, match=r"stages\.screening\.fidelity: only demcal's"):
        parse_study(data)


def _pool_calls(study_file, monkeypatch, counts, **runner_kw):
    """Run ``n`` new points of the stage "rsm" for each n in ``counts`` through a Runner on 2
    workers; return, per n, the local pool's calls as (workers, chunk sizes)."""
    import demcal.calibrate.runner as runner_mod
    from demcal.calibrate.pipeline import test_def

    calls: list[tuple[int, list[int]]] = []

    def fake_local(chunks, on_result, *, workers=1, threads_per_worker=1):
        calls.append((workers, [len(c) for c in chunks]))
        for c in chunks:
            for r in REAL_RUN_CHUNK(c):
                on_result(r)

    monkeypatch.setattr(runner_mod, "run_local", fake_local)
    study = parse_study(tomllib.loads(study_file.read_text()))
    full = preset_parameters("corn_stalk")
    out = {}
    with RunStore(study_file.parent) as store:
        runner = Runner(store, test_def(study), RunnerOptions(workers=2, **runner_kw))
        for n in counts:
            calls.clear()
            points = [Point(point=i, replicate=0, seed=1000 * n + i,
                            params={**full, "pp.static_friction": 0.3 + 0.01 * i})
                      for i in range(n)]
            runner.run("rsm", points)
            out[n] = list(calls)
    return out


def test_the_pool_s_chunks_leave_no_worker_idle(study_file, monkeypatch):
    """4 verification runs of one design point on 2 workers: two tasks of 2, not 3 + 1; 3 runs
    stay one task (it runs in this process on every thread)."""
    calls = _pool_calls(study_file, monkeypatch, (4, 3, 12), chunk=3)
    for n, want in ((4, [2, 2]), (3, [3]), (12, [3, 3, 3, 3])):
        assert sorted(size for _, sizes in calls[n] for size in sizes) == want, n


def test_spread_runs_lone_runs_in_full_rounds_and_batches_the_rest_here(study_file,
                                                                        monkeypatch):
    """The CPU's default (``spread``): one run per task on the pool in full rounds of the
    workers, the rest as one batch in this process (``workers=1``: every thread)."""
    calls = _pool_calls(study_file, monkeypatch, (4, 3, 5, 1), chunk=3, spread=True)
    assert calls == {4: [(2, [1, 1, 1, 1])], 3: [(2, [1, 1]), (1, [1])],
                     5: [(2, [1, 1, 1, 1]), (1, [1])], 1: [(2, [1])]}


def test_a_study_spreads_on_the_cpu_unless_it_sets_a_chunk(two_fidelity_study, monkeypatch):
    """An engine study on the CPU spreads its runs (``executor.chunk`` unset); with a chunk
    set it keeps its chunks."""
    import demcal.calibrate.pipeline as pipeline_mod

    path, _ = two_fidelity_study
    seen: list[tuple[int, bool]] = []
    real = pipeline_mod.Runner

    def spy(store, test, options):
        seen.append((options.chunk, options.spread))
        return real(store, test, options)

    monkeypatch.setattr(pipeline_mod, "Runner", spy)
    monkeypatch.setattr("demcal.dem.backends.resolve_backend", lambda backend: "cpu")
    text = path.read_text()
    for body, want in ((text, (1, True)),  # the example's replicates = 1
                       (text.replace("[executor]\n", "[executor]\nchunk = 3\n"), (3, False))):
        path.write_text(body)
        seen.clear()
        ctx = pipeline_mod.open_study(path)
        ctx.store.close()
        assert seen == [want]


def test_a_lammps_study_takes_a_stage_at_the_factory_fill(example_data):
    """LAMMPS writes the paper fidelity's factory fill too: a stage at 'paper' is taken."""
    data = dict(example_data)
    data["test"] = {"kind": "aor", "fidelity": "quick"}
    data["executor"] = {"engine": "lammps"}
    data["stages"] = {**data["stages"], "screening": {"fidelity": "paper"}}
    assert parse_study(data).stage_fidelities() == {"screening": "paper"}
