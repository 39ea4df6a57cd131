"""How much of a pile's seed-to-seed scatter the *measurement* makes, on saved piles.

The piles saved by ``benchmarks/precision.py`` (``--out``: one ``.npz`` of final spheres per
seed) are measured again, without simulating, in two ways that keep the pile fixed:

- **view sampling**: the silhouette angle from 8 views, and from the same 8 views turned by
  1/4, 1/2 and 3/4 of the views' spacing (another, equally valid set of photos of the same
  pile). The spread of the four about their mean is the noise that the choice of views adds
  to one pile's angle; compared with the seed-to-seed std it says whether more views could
  help;
- **fit window**: the angle with the flank line fitted over other height windows (fractions
  of the pile height; demcal's default is 0.2-0.8) on the same piles. For each window: the
  mean and seed-to-seed std per folder, the Pitman-Morgan test of equal variance against the
  default window (paired: the same piles), the std pooled over folders and, for two folders
  (two parameter sets), the signal (difference of their means) over the pooled std.

A window changes *what is measured* (a cohesive pile's flank is not straight: the upper part
is steeper), so it must be the same for photos and simulations; this benchmark only says what
each window would cost or buy in scatter and in signal.

Usage::

    python benchmarks/measure_scatter.py steep=out/steep/1200_0.056 opt=out/opt/1200_0.056
    python benchmarks/measure_scatter.py a=out/a --json measure_scatter.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy import stats

from demcal import measure

#: fit windows compared (fractions of the pile height); the first is demcal's default
WINDOWS: list[tuple[float, float]] = [
    measure.DEFAULT_FIT_WINDOW, (0.1, 0.7), (0.15, 0.7), (0.2, 0.7), (0.1, 0.6), (0.3, 0.7),
    (0.1, 0.8), (0.1, 0.9)]
#: turns of the 8-view set, in units of the views' spacing (180 / 8 deg)
TURNS = (0.0, 0.25, 0.5, 0.75)
N_VIEWS = 8


def _turned(centres: np.ndarray, degrees: float) -> np.ndarray:
    """Sphere centres (n, 3) m turned about the vertical axis by ``degrees``."""
    a = np.radians(degrees)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0],
                    [0.0, 0.0, 1.0]])
    return centres @ rot.T


def measure_pile_file(path: Path) -> dict:
    """One saved pile: its angle (deg) per view turn and per fit window."""
    with np.load(path) as data:
        centres, radii = data["centres"], data["radii"]
    spacing = 180.0 / N_VIEWS
    turns = [measure.pile_aor_silhouette(_turned(centres, t * spacing), radii,
                                         n_views=N_VIEWS).aor_deg for t in TURNS]
    windows = {f"{lo:g}-{hi:g}": measure.pile_aor_silhouette(
        centres, radii, n_views=N_VIEWS, fit_window=(lo, hi)).aor_deg for lo, hi in WINDOWS}
    return {"file": str(path), "turns_deg": turns, "windows_deg": windows}


def _std(values: np.ndarray) -> float:
    return float(np.std(values, ddof=1)) if len(values) > 1 else float("nan")


def view_sampling(piles: list[dict]) -> dict:
    """The spread one pile's angle owes to the choice of views, against the seed scatter."""
    turns = np.array([p["turns_deg"] for p in piles], dtype=float)
    within = float(np.sqrt(np.mean(np.var(turns, axis=1, ddof=1))))
    return {"view_sampling_std_deg": within, "seed_std_deg": _std(turns[:, 0]),
            "seed_std_of_four_view_sets_deg": _std(turns.mean(axis=1))}


def window_rows(folders: dict[str, list[dict]]) -> list[dict]:
    """Per fit window: mean, seed std and the paired variance test per folder; pooled std."""
    base = f"{WINDOWS[0][0]:g}-{WINDOWS[0][1]:g}"
    rows = []
    for key in (f"{lo:g}-{hi:g}" for lo, hi in WINDOWS):
        row: dict = {"window": key, "folders": {}}
        variances, dofs, means = [], [], []
        for name, piles in folders.items():
            v = np.array([p["windows_deg"][key] for p in piles], dtype=float)
            b = np.array([p["windows_deg"][base] for p in piles], dtype=float)
            # Pitman-Morgan: equal variances of paired samples <=> corr(sum, difference) = 0
            p_equal = 1.0 if key == base or len(v) < 3 else float(
                stats.pearsonr(v + b, v - b).pvalue)
            row["folders"][name] = {"mean_deg": float(np.mean(v)), "seed_std_deg": _std(v),
                                    "n": len(v), "pitman_morgan_p": p_equal}
            variances.append(np.var(v, ddof=1))
            dofs.append(len(v) - 1)
            means.append(float(np.mean(v)))
        row["pooled_std_deg"] = float(np.sqrt(np.dot(variances, dofs) / sum(dofs)))
        if len(means) == 2:
            row["signal_deg"] = means[0] - means[1]
            row["signal_over_std"] = row["signal_deg"] / row["pooled_std_deg"]
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", help="NAME=FOLDER of saved piles (seed*.npz)")
    ap.add_argument("--json", help="write the numbers to this file")
    args = ap.parse_args()
    folders: dict[str, list[dict]] = {}
    for item in args.folders:
        name, _, folder = item.partition("=")
        files = sorted(Path(folder).glob("seed*.npz"))
        if len(files) < 2:
            ap.error(f"{item}: needs at least 2 saved piles (seed*.npz); found {len(files)}")
        folders[name] = [measure_pile_file(f) for f in files]
    views = {name: view_sampling(piles) for name, piles in folders.items()}
    rows = window_rows(folders)
    for name, v in views.items():
        print(f"{name}: view sampling {v['view_sampling_std_deg']:.2f} deg per pile, "
              f"seed std {v['seed_std_deg']:.2f} (mean of 4 view sets "
              f"{v['seed_std_of_four_view_sets_deg']:.2f})")
    for r in rows:
        cells = "  ".join(f"{n}: {c['mean_deg']:6.2f} +/- {c['seed_std_deg']:4.2f} "
                          f"(PM p {c['pitman_morgan_p']:.2f})" for n, c in r["folders"].items())
        extra = (f"  signal {r['signal_deg']:5.2f} = {r['signal_over_std']:.2f} std"
                 if "signal_deg" in r else "")
        print(f"{r['window']:>9}  {cells}  pooled std {r['pooled_std_deg']:4.2f}{extra}")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"view_sampling": views, "windows": rows, "piles": folders}, indent=1))


if __name__ == "__main__":
    main()
