"""The drum test's settings: fidelities, overrides and one-line refusals."""

import pytest

from demcal.errors import InputError
from demcal.virtual.drum_settings import DrumSettings, critical_rpm, drum_settings, froude


def test_fidelities_and_their_froude_numbers():
    quick, standard = drum_settings("quick"), drum_settings("standard")
    assert quick.diameter < standard.diameter
    assert quick.frames * quick.frame_interval_s < standard.frames * standard.frame_interval_s
    assert quick.froude == pytest.approx((30 * 2 * 3.141592653589793 / 60) ** 2 * 0.03 / 9.81)
    assert froude(critical_rpm(0.1), 0.1) == pytest.approx(1.0)


def test_overrides_reach_the_drum_the_particle_and_the_engine():
    s = drum_settings("quick", {"drum": {"rpm": 15, "fill_fraction": 0.3},
                                "particle": {"n_spheres": 5}, "rolling_model": "C"})
    assert (s.rpm, s.fill_fraction, s.particle.n_spheres, s.rolling_model) == (15, 0.3, 5, "C")


@pytest.mark.parametrize(("drum", "words"), [
    ({"fill_fraction": 1.2}, r"drum.fill_fraction must be in \(0, 1\); got 1.2 \(a fill of 100"),
    ({"fill_fraction": 1.0}, r"drum.fill_fraction must be in \(0, 1\)"),
    ({"fill_fraction": 0}, r"drum.fill_fraction must be in \(0, 1\); got 0"),
    ({"rpm": 200}, r"Froude number .* >= 1: the material centrifuges; the critical speed of a "
                   r"60 mm drum is 172.7 rpm"),
    ({"width": 0.02}, r"drum.width: the drum's width \(20 mm\) must be at least 2 particle "
                      r"sizes \(25 mm"),
    ({"diameter": 0.04}, r"drum.diameter: the drum's radius \(20 mm\) must be at least 2"),
    ({"rpm": -1}, r"drum.rpm must be in \[0, 10000\]"),
    ({"frames": 2.5}, r"drum.frames must be a whole number"),
    ({"rpm": float("nan")}, r"drum.rpm must be a finite number"),
    ({"rpm": "fast"}, r"drum.rpm must be a finite number; got 'fast'"),
    ({"speed": 3}, r"drum.speed is not a drum setting; use one of "),
    ({"wall_static_friction": -0.1}, r"drum.wall_static_friction must be in \[0, 10\] \(the "
                                     r"drum's pw.static_friction\); got -0.1"),
    ({"wall_restitution": 0}, r"drum.wall_restitution must be in \(0, 1\]"),
    ({"wall_rolling_friction": float("inf")}, r"drum.wall_rolling_friction must be a finite"),
])
def test_bad_settings_are_refused_in_one_line(drum, words):
    with pytest.raises(InputError, match=words) as err:
        drum_settings("quick", {"drum": drum})
    assert "\n" not in str(err.value)


def test_other_refusals():
    with pytest.raises(InputError, match="fidelity must be one of quick, standard"):
        drum_settings("paper")
    with pytest.raises(InputError, match="--test geometry: not a drum test setting"):
        drum_settings("quick", {"geometry": {"plate_size": 1}})
    with pytest.raises(InputError, match=r"particle: size_max \(0.5\) must be >= size_min"):
        drum_settings("quick", {"particle": {"size_max": 0.5}})
    with pytest.raises(InputError, match="rolling_model must be A, C or none"):
        DrumSettings(rolling_model="B")
    with pytest.raises(InputError, match=r"drum.count must be a whole number in \[10, 100000\]"):
        DrumSettings(count=3)


def test_the_drums_own_lining_replaces_the_particle_wall_values_in_the_drum_only():
    plain = drum_settings("quick")
    assert plain.wall_overrides() == {}
    lined = drum_settings("quick", {"drum": {"wall_static_friction": 0.9,
                                             "wall_rolling_friction": 0.0}})
    assert lined.wall_overrides() == {"pw.static_friction": 0.9, "pw.rolling_friction": 0.0}


def test_an_unset_lining_leaves_a_stored_drum_runs_identity_as_it_was():
    """Drum runs stored before the lining existed are reused: its unset fields are not part
    of the identity; a set one is."""
    from demcal.execute.tasks import TestDef

    plain = TestDef(kind="drum", fidelity="quick", overrides={"drum": {"rpm": 20}})
    ident = plain.identity()["config"]
    assert not any(k.startswith("wall_") for k in ident)
    assert ident["rpm"] == 20
    lined = TestDef(kind="drum", fidelity="quick",
                    overrides={"drum": {"rpm": 20, "wall_static_friction": 0.9}})
    assert lined.identity()["config"]["wall_static_friction"] == 0.9
    assert lined.identity() != plain.identity()
