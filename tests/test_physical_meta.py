"""The store's meta ``physical``, typed where the report reads it (demcal.summaries.physical_meta):
read from what ``derive_parameters(...).to_dict()`` writes, so a renamed key of the bench's
statistics or table fails here, and old or crafted stores still read."""

from __future__ import annotations

from pathlib import Path

import pytest

from demcal.physical import derive_parameters, load_measurements
from demcal.summaries.physical_meta import PhysicalMeta

MEASUREMENTS = Path(__file__).resolve().parents[1] / "examples" / "corn_stalk" / "measurements.toml"


def test_the_bench_s_derived_values_read_typed():
    res = derive_parameters(load_measurements(MEASUREMENTS))
    meta = PhysicalMeta.from_summary(res.to_dict())
    assert set(meta.summaries) == set(res.summaries) and meta.summaries
    for key, s in res.summaries.items():
        got = meta.summaries[key]
        assert (got.name, got.unit, got.n_repeats, got.range_only) == (
            s.name, s.unit, s.n_repeats, s.range_only)
        assert (got.mean, got.std, got.minimum, got.maximum) == (
            s.mean, s.std, s.minimum, s.maximum)
        assert (got.ci_low, got.ci_high, got.ci_level) == (s.ci_low, s.ci_high, s.level)
    rows = {r["name"]: r for r in res.table_rows()}
    assert set(meta.rows) == set(rows)
    for name, row in meta.rows.items():
        assert (row.symbol, row.display, row.source) == (
            rows[name]["symbol"], rows[name]["display"], rows[name]["source"])
    assert res.target_aor is not None and meta.target_aor is not None
    assert meta.target_aor.mean == pytest.approx(res.target_aor.mean)


@pytest.mark.parametrize("stored", [
    None, {}, {"density_kg_m3": 114.36},  # no bench data; a flat record of an early release
    {"derived": "junk"}, {"derived": {"table": "junk", "summaries": ["x"]}},
    {"derived": {"table": [3, {"name": "particle.density"}], "summaries": {"a": 1},
                 "target_aor_deg": 44.1}},
])
def test_old_and_crafted_physical_meta_read(stored):
    meta = PhysicalMeta.from_summary(stored)
    assert meta.summaries == {} and meta.target_aor is None
    assert set(meta.rows) <= {"particle.density"}
