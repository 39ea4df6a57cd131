"""Materials and pair interactions, and their packing into per-world pair tables.

A :class:`Material` is a bulk solid (density, shear modulus, Poisson ratio); an
:class:`Interaction` describes a pair of materials (restitution, static friction, rolling
friction, JKR surface energy), as in EDEM. A :class:`MaterialTable` holds both for one world.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from demcal.dem.contact import (
    N_PAIR_FIELDS,
    P_BETA,
    P_ESTAR,
    P_GAMMA,
    P_GSTAR,
    P_JKR_C,
    P_JKR_K,
    P_MU_R,
    P_MU_S,
    beta_from_restitution,
    jkr_constants,
    jkr_critical_overlap,
    pair_modulus,
    pair_shear_modulus,
)
from demcal.errors import InputError

__all__ = ["Interaction", "Material", "MaterialTable"]


def _check(name: str, value: float, lo: float, hi: float, *, lo_open=False, hi_open=False,
           unit: str = "") -> float:
    v = float(value)
    ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        hi_s = "inf" if math.isinf(hi) else f"{hi:g}"
        raise InputError(f"{name} must be in {lb}{lo:g}, {hi_s}{rb}{unit}; got {value!r}")
    return v


@dataclass(frozen=True)
class Material:
    """A bulk material.

    Parameters
    ----------
    name : str
        Unique name.
    density : float
        Solid density, kg/m^3 (> 0).
    shear_modulus : float
        Shear modulus G, Pa (> 0).
    poisson : float
        Poisson ratio, in [0, 0.5).
    """

    name: str
    density: float
    shear_modulus: float
    poisson: float

    def __post_init__(self):
        _check(f"{self.name}.density", self.density, 0, math.inf, lo_open=True, unit=" kg/m^3")
        _check(f"{self.name}.shear_modulus", self.shear_modulus, 0, math.inf, lo_open=True,
               unit=" Pa")
        _check(f"{self.name}.poisson", self.poisson, 0, 0.5, hi_open=True)

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus ``E = 2 G (1 + v)``, Pa."""
        return 2.0 * self.shear_modulus * (1.0 + self.poisson)


@dataclass(frozen=True)
class Interaction:
    """Contact parameters of a pair of materials (EDEM's meaning).

    Parameters
    ----------
    restitution : float
        Coefficient of restitution, in (0, 1].
    static_friction : float
        Static (sliding) friction coefficient mu_s, >= 0.
    rolling_friction : float
        Rolling friction coefficient mu_r, >= 0 (dimensionless, EDEM's).
    surface_energy : float
        JKR surface energy gamma, J/m^2 (>= 0; 0 gives plain Hertz-Mindlin).
    """

    restitution: float
    static_friction: float
    rolling_friction: float = 0.0
    surface_energy: float = 0.0

    def validated(self, label: str) -> Interaction:
        _check(f"{label}.restitution", self.restitution, 0, 1, lo_open=True)
        _check(f"{label}.static_friction", self.static_friction, 0, math.inf)
        _check(f"{label}.rolling_friction", self.rolling_friction, 0, math.inf)
        _check(f"{label}.surface_energy", self.surface_energy, 0, math.inf, unit=" J/m^2")
        return self


class MaterialTable:
    """The materials of one world and the interaction of every pair of them.

    Parameters
    ----------
    materials : sequence of Material
        Particle and wall materials (unique names).
    interactions : mapping (name_a, name_b) -> Interaction
        One entry per unordered pair that can touch; ``(a, b)`` and ``(b, a)`` are the same.
        Pairs that are missing are refused when a pair table is needed.
    """

    def __init__(self, materials: Sequence[Material],
                 interactions: Mapping[tuple[str, str], Interaction]):
        names = [m.name for m in materials]
        if len(set(names)) != len(names):
            raise InputError(f"material names must be unique; got {names}")
        if not materials:
            raise InputError("a material table needs at least one material")
        self.materials = list(materials)
        self._index = {n: i for i, n in enumerate(names)}
        self.interactions: dict[tuple[str, str], Interaction] = {}
        for (a, b), inter in interactions.items():
            for n in (a, b):
                if n not in self._index:
                    raise InputError(f"interaction ({a}, {b}) names unknown material {n!r}; "
                                     f"known: {', '.join(names)}")
            key = tuple(sorted((a, b)))
            self.interactions[key] = inter.validated(f"interaction[{key[0]}-{key[1]}]")

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.materials]

    def index(self, name: str) -> int:
        """Index of a material by name (InputError if unknown)."""
        try:
            return self._index[name]
        except KeyError:
            raise InputError(f"unknown material {name!r}; known: {', '.join(self.names)}") \
                from None

    def material(self, name: str) -> Material:
        return self.materials[self.index(name)]

    def interaction(self, a: str, b: str) -> Interaction:
        key = tuple(sorted((a, b)))
        if key not in self.interactions:
            raise InputError(f"no interaction given for materials {a!r} and {b!r}")
        return self.interactions[key]

    def pair_table(self) -> np.ndarray:
        """Pair parameters, ``(n_mat, n_mat, N_PAIR_FIELDS)`` float64 (E*, G*, beta, mu_s,
        mu_r, gamma and the JKR constants of :func:`~demcal.dem.contact.jkr_constants`);
        pairs without an interaction get NaN (never touched if unused)."""
        n = len(self.materials)
        table = np.full((n, n, N_PAIR_FIELDS), np.nan)
        for (a, b), inter in self.interactions.items():
            ia, ib = self._index[a], self._index[b]
            ma, mb = self.materials[ia], self.materials[ib]
            row = np.empty(N_PAIR_FIELDS)
            row[P_ESTAR] = pair_modulus(ma.youngs_modulus, ma.poisson, mb.youngs_modulus,
                                        mb.poisson)
            row[P_GSTAR] = pair_shear_modulus(ma.shear_modulus, ma.poisson, mb.shear_modulus,
                                              mb.poisson)
            row[P_BETA] = beta_from_restitution(inter.restitution)
            row[P_MU_S] = inter.static_friction
            row[P_MU_R] = inter.rolling_friction
            row[P_GAMMA] = inter.surface_energy
            row[P_JKR_C], row[P_JKR_K] = jkr_constants(row[P_ESTAR], row[P_GAMMA])
            table[ia, ib] = row
            table[ib, ia] = row
        return table

    def max_contact_margin(self, max_eff_radius: float) -> float:
        """Largest JKR break-off gap |d_c| over all pairs, for R* up to ``max_eff_radius``, m."""
        table = self.pair_table()
        margin = 0.0
        n = len(self.materials)
        for ia in range(n):
            for ib in range(n):
                g = table[ia, ib, P_GAMMA]
                if np.isfinite(g) and g > 0:
                    margin = max(margin, -jkr_critical_overlap(max_eff_radius,
                                                               table[ia, ib, P_ESTAR], g))
        return margin
