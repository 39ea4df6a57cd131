"""The SQLite run store: round trips, identity of runs, durability across processes."""

import math
import subprocess
import sys

import pytest

from demcal.store import RunRecord, RunStore, params_hash, run_key


def _run(key="screening:x", aor=40.0, status="done", **kw):
    return RunRecord(key=key, stage="screening", point=1, replicate=0,
                     params={"pp.static_friction": 0.5}, seed=7, status=status,
                     outcome="pile", responses={} if aor is None else {"aor_deg": aor},
                     result={"aor_deg": aor}, **kw)


def test_round_trip_and_replace(tmp_path):
    with RunStore(tmp_path) as store:
        store.record_run(_run())
        store.record_run(_run(aor=41.5))
        (got,) = store.runs("screening")
        assert got.aor_deg == 41.5 and got.params == {"pp.static_friction": 0.5}
        assert store.count() == 1 and store.get_run("nope") is None


def test_nan_becomes_null_and_bad_status_refused(tmp_path):
    with RunStore(tmp_path / "s.sqlite") as store:
        store.record_run(_run(aor=math.nan, status="failed", reason="unstable"))
        assert store.runs(status="failed")[0].aor_deg is None
        with pytest.raises(ValueError, match="status"):
            store.record_run(_run(status="pending"))


def test_keys_order_free_and_seed_sensitive():
    a = {"x": 0.1, "y": 2.0}
    assert params_hash(a) == params_hash(dict(reversed(list(a.items()))))
    assert run_key("rsm", a, 1) != run_key("rsm", a, 2)
    assert run_key("rsm", a, 1, "t1") != run_key("rsm", a, 1, "t2")
    assert params_hash({"x": 0.1}) != params_hash({"x": 0.1 + 1e-15})


def test_writes_are_visible_to_another_process_at_once(tmp_path):
    with RunStore(tmp_path) as store:
        store.record_run(_run())
        store.set_stage("screening", "done", {"selected": ["pp.static_friction"]})
        store.set_meta("target", {"aor_deg": 44.12})
        code = (f"from demcal.store import RunStore; s = RunStore(r'{tmp_path}'); "
                "print(s.count(), s.stage('screening').summary['selected'][0], "
                "s.meta('target')['aor_deg'])")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True).stdout.split()
        assert out == ["1", "pp.static_friction", "44.12"]
