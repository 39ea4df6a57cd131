"""Fault tolerance: a study interrupted after k runs and restarted does every run once;
a changed study re-runs only what changed; failed runs are retried once with a smaller step."""

from __future__ import annotations

from collections import Counter

import pytest

import demcal.execute.tasks as tasks
from demcal.calibrate import calibrate
from demcal.store import RunStore

REAL_RUN_CHUNK = tasks.run_chunk


class Killed(BaseException):
    """Stands for Ctrl-C / a kill: a BaseException, like KeyboardInterrupt."""


class Counting:
    """Wraps run_chunk: counts every run key executed; raises after ``fail_after`` runs."""

    def __init__(self, fail_after: int | None = None):
        self.keys: Counter[str] = Counter()
        self.fail_after = fail_after

    def __call__(self, chunk, on_result=None):
        out = []
        for t in chunk:
            if self.fail_after is not None and sum(self.keys.values()) >= self.fail_after:
                raise Killed  # in the middle of the screening stage
            out += REAL_RUN_CHUNK([t], on_result)
            self.keys[t.key] += 1
        return out


def test_killed_mid_stage_and_restarted_runs_each_once(study_file, monkeypatch):
    first = Counting(fail_after=11)  # 5 rangefind runs + 6 of the 12 screening runs
    monkeypatch.setattr(tasks, "run_chunk", first)
    with pytest.raises(Killed):
        calibrate(study_file)
    with RunStore(study_file.parent) as store:
        assert store.count() == 11 and store.count("screening") == 6
        assert store.stage("screening").status == "running"
    second = Counting()
    monkeypatch.setattr(tasks, "run_chunk", second)
    res = calibrate(study_file)
    assert not set(first.keys) & set(second.keys)
    every = first.keys + second.keys
    assert all(n == 1 for n in every.values())
    with RunStore(study_file.parent) as store:
        assert sorted(every) == sorted(r.key for r in store.runs())
    assert res["n_runs"] == len(every) == 40
    # a third call runs nothing and gives the same answer
    third = Counting()
    monkeypatch.setattr(tasks, "run_chunk", third)
    assert calibrate(study_file)["optimum"] == res["optimum"]
    assert sum(third.keys.values()) == 0


def test_changed_study_reruns_only_what_changed(study_file, monkeypatch):
    res = calibrate(study_file)
    study_file.write_text(study_file.read_text().replace("[stages.verification]\nn = 3",
                                                         "[stages.verification]\nn = 5"))
    counter = Counting()
    monkeypatch.setattr(tasks, "run_chunk", counter)
    res2 = calibrate(study_file)
    assert sum(counter.keys.values()) == 2  # two more verification replicates only
    assert res2["optimum"] == res["optimum"] and res2["verification"]["n"] == 5


def test_unstable_run_is_stored_and_retried_with_a_smaller_step(study_file):
    text = study_file.read_text().replace(
        'no_pile_above = {', 'unstable_above = { "pw.static_friction" = 0.75 }\nno_pile_above = {')
    study_file.write_text(text)
    res = calibrate(study_file)
    with RunStore(study_file.parent) as store:
        retried = [r for r in store.runs() if r.attempts == 2]
        assert retried and all(r.params["pw.static_friction"] > 0.75 for r in retried)
        for r in retried:
            assert r.status == "done" and r.outcome == "pile"
            assert "retried with dt_fraction x0.5" in r.reason and "unstable" in r.reason
            assert r.result["first_attempt"]["outcome"] == "unstable"
    assert res["verification"]["relative_error_percent"] < 2.5


def test_a_resume_on_another_machine_keeps_the_optimum_and_its_verification(study_file,
                                                                            another_machine):
    # Another machine's BLAS and numpy move the optimizer's answer in the 8th digit; the
    # verification's runs are keyed by their exact parameters, so a resume that took the new
    # answer would run them again. The stored optimum still hits the target: it is kept.
    first, again = another_machine(study_file)
    assert again["n_runs_executed"] == 0
    assert again["optimum"] == first["optimum"] and again["verification"] == first["verification"]
    # a different target is a different problem: the optimum is found anew (perturbed here)
    text = study_file.read_text()
    assert "aor_deg = 40.0" in text
    study_file.write_text(text.replace("aor_deg = 40.0", "aor_deg = 40.5"))
    moved = calibrate(study_file, workers=1)
    assert moved["optimum"] != first["optimum"] and moved["n_runs_executed"] > 0
