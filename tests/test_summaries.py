"""The typed verification summary: what the stage stores, the report and the result JSON read."""

from __future__ import annotations

import gzip
import shutil
import sqlite3
from pathlib import Path

from demcal.summaries import ResponseVerification, Verification, stored_key

DATA = Path(__file__).parent / "data"

#: The keys a single-response, single-round verification stores, in order. The result JSON,
#: the material card and old stores read these names: renaming one must fail here.
STORED_KEYS = [
    "params", "aor_deg", "outcomes", "aor_mean_deg", "aor_std_deg", "relative_error_percent",
    "n", "n_piles", "pile_png", "half_width_deg", "half_width_goal_deg", "half_width_reached",
    "sized_with_std_deg", "sized_with_df", "ci_low_deg", "ci_high_deg", "target_in_interval",
    "p_value", "test", "consistent", "tolerance_percent", "within_tolerance",
    "confirm_pi_low_deg", "confirm_pi_high_deg", "confirmed"]


def _stored_verification(path: Path) -> dict:
    import json

    con = sqlite3.connect(path)
    try:
        row = con.execute("SELECT summary_json FROM stages WHERE name = 'verification'").fetchone()
    finally:
        con.close()
    return json.loads(row[0])


def test_a_single_response_verification_stores_the_keys_it_always_stored():
    ver = Verification(params={"pp.static_friction": 0.5}, values=[40.0, None],
                       outcomes=["pile", "column"], n=2, n_piles=1, mean=40.0)
    assert list(ver.to_summary()) == STORED_KEYS
    assert Verification.from_summary(ver.to_summary()) == ver


def test_responses_and_rounds_round_trip():
    check = ResponseVerification(values=[1.0, 1.2], mean=1.1, std=0.14, n=2,
                                 lab={"mean": 1.05, "std": 0.1, "n": 5}, consistent=True)
    first = Verification(n=3, n_piles=3, mean=41.0, confirmed=False)
    ver = Verification(n=3, n_piles=3, mean=40.1, responses={"bulk": check}, round=2,
                       rounds=[first])
    stored = ver.to_summary()
    assert stored["round"] == 2 and stored["rounds"][0]["aor_mean_deg"] == 41.0
    assert stored["responses"]["bulk"]["lab"]["n"] == 5
    back = Verification.from_summary(stored)
    assert back == ver and back.round_number == 2 and back.rounds[0].round_number == 1


def test_an_old_store_reads_and_an_empty_summary_is_not_verified(tmp_path):
    # the verification a schema-1 store (the release before several responses) holds
    db = tmp_path / "old.sqlite"
    with gzip.open(DATA / "store_v1_analytic.sqlite.gz", "rb") as src, db.open("wb") as dst:
        shutil.copyfileobj(src, dst)
    stored = _stored_verification(db)
    ver = Verification.from_summary(stored)
    assert ver.done and ver.n == len(ver.values) == len(ver.outcomes) >= 3
    assert ver.mean == stored["aor_mean_deg"] and ver.responses is None
    assert {k: v for k, v in ver.to_summary().items() if k in stored} == \
        {k: v for k, v in stored.items() if k in STORED_KEYS}
    empty = Verification.from_summary({})
    assert not empty.done and empty.round_number == 1


def test_keys_a_newer_release_adds_are_left_out_not_refused():
    ver = Verification.from_summary({"n": 2, "n_piles": 2, "some_future_key": 1.0})
    assert ver.n == 2 and "some_future_key" not in ver.to_summary()


def test_the_result_json_s_verification_keeps_its_keys():
    """The result JSON's ``verification`` is built from the fields (``in_result``) under their
    stored keys: a user's scripts read these names."""
    ver = Verification(values=[40.0, 41.0], n=2, n_piles=2, mean=40.5, std=0.7, ci_low=34.2)
    out = ver.in_result()
    assert list(out) == [
        "aor_mean_deg", "aor_std_deg", "relative_error_percent", "n", "ci_low_deg",
        "ci_high_deg", "p_value", "consistent", "test", "half_width_deg",
        "half_width_goal_deg", "half_width_reached", "confirm_pi_low_deg",
        "confirm_pi_high_deg", "confirmed", "target_in_interval", "tolerance_percent",
        "within_tolerance", "aor_deg"]
    assert out["aor_mean_deg"] == 40.5 and out["ci_low_deg"] == 34.2
    assert out["aor_deg"] == [40.0, 41.0]
    assert stored_key(Verification, "mean") == "aor_mean_deg"
    assert stored_key(ver, "n") == "n"
