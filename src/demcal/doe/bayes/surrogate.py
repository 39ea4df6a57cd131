"""Gaussian-process surrogates: one per response, over the coded box [-1, 1]^k.

A surrogate answers "what would the simulation's mean response be here, and how sure are we"
for any coded setting, so that the posterior can be sampled without running the simulation.
The kernel is ``C * Matern(nu=2.5, anisotropic) + White``: Matern 5/2 because DEM responses are
smooth but not analytic in the contact parameters; one length scale per factor because the
factors matter very differently (an unimportant factor gets a long length scale); a white
noise term because a simulated response scatters from seed to seed. When replicate variances
are known, they are given per point (``alpha``) instead of the learned white term.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from scipy.linalg import cho_solve, solve_triangular
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
from threadpoolctl import threadpool_limits

from demcal.errors import InputError

__all__ = ["Predictor", "Surrogate", "coded_points", "fit_surrogate"]

#: Smallest predictive variance, in standardised units: keeps the likelihood finite at a
#: training point of a noise-free fit.
_MIN_VAR = 1e-12


class Predictor(Protocol):
    """Anything with ``predict(x) -> (mean, std)``: a :class:`Surrogate` or an exact model."""

    def predict(self, x: Any) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - protocol
        """Mean and standard deviation of the response at coded points ``x``."""
        ...


def coded_points(x: Any, k: int | None = None, what: str = "x") -> np.ndarray:
    """Validate coded settings: a finite (n, k) float array.

    Parameters
    ----------
    x : array_like of float
        Coded settings, one row per point (a single point may be 1-D).
    k : int, optional
        Expected number of factors (columns).
    what : str, optional
        Name used in the error message.

    Returns
    -------
    (n, k) ndarray of float64

    Raises
    ------
    InputError
        If ``x`` is not 2-D after promotion, has the wrong width or holds a non-finite value.
    """
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] == 0:
        raise InputError(f"{what} must be an (n_points, n_factors) array; got shape {arr.shape}")
    if k is not None and arr.shape[1] != k:
        raise InputError(f"{what} must have {k} columns (one per factor); got {arr.shape[1]}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{what} must hold finite coded settings")
    return arr


@dataclass(frozen=True, eq=False)
class Surrogate:
    """A fitted Gaussian process for one response.

    Attributes
    ----------
    name : str
        The response's name.
    x : (n, k) ndarray of float64
        Coded settings it was fitted on.
    y : (n,) ndarray of float64
        Observed responses there, in the response's unit.
    noise_var : (n,) ndarray of float64 or None
        Per-point variance of ``y`` given at fit time (unit²), or None when the white-noise
        term was learned.
    kernel : str
        The fitted kernel, as scikit-learn prints it (standardised units).
    noise_std : float
        The fitted run-to-run scatter, in the response's unit: the white term's or, with
        ``noise_var``, the root mean of it.
    log_marginal_likelihood : float
        Of the fitted hyperparameters.
    """

    name: str
    x: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    noise_var: np.ndarray | None = field(repr=False)
    kernel: str
    noise_std: float
    log_marginal_likelihood: float
    _gp: Any = field(repr=False)
    _y_mean: float = field(repr=False)
    _y_scale: float = field(repr=False)
    _latent: Any = field(repr=False)

    @property
    def n_factors(self) -> int:
        """Number of coded factors."""
        return int(self.x.shape[1])

    def predict(self, x: Any) -> tuple[np.ndarray, np.ndarray]:
        """Mean response and the standard deviation of that mean at coded points.

        The standard deviation is the *latent* function's (how well the surrogate knows the
        simulation's mean response there), without the run-to-run scatter: the lab compares
        with the mean response, not with one noisy run.

        Parameters
        ----------
        x : (n, k) or (k,) array_like of float
            Coded settings.

        Returns
        -------
        mean, std : (n,) ndarray of float64
            In the response's unit.
        """
        pts = coded_points(x, self.n_factors)
        # scikit-learn's own predict, minus its input checks and the white-noise term on the
        # diagonal (the *latent* variance): the sampler calls this tens of thousands of times.
        gp = self._gp
        k_trans = self._latent(pts, gp.X_train_)
        mean = k_trans @ gp.alpha_
        v = solve_triangular(gp.L_, k_trans.T, lower=True, check_finite=False)
        var = np.maximum(self._latent.diag(pts) - np.einsum("ij,ij->j", v, v), _MIN_VAR)
        return self._y_mean + self._y_scale * mean, self._y_scale * np.sqrt(var)

    def leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Each run predicted from the others: the mean and the standard deviation of *one
        run* there (the run-to-run scatter included), with the fitted hyperparameters kept.

        Closed form for a Gaussian process (Rasmussen & Williams 2006, eq. 5.12): with
        ``K`` the training covariance (noise included), ``mu_-i = y_i - [K^-1 y]_i /
        [K^-1]_ii`` and ``var_-i = 1 / [K^-1]_ii``; no refit, so it costs one inverse.

        Returns
        -------
        mean, std : (n,) ndarray of float64
            In the response's unit, one per training run (``x``, ``y`` order).
        """
        gp = self._gp
        k_inv = cho_solve((gp.L_, True), np.eye(len(self.y)), check_finite=False)
        diag = np.diag(k_inv)
        z = (self.y - self._y_mean) / self._y_scale
        mean = z - (k_inv @ z) / diag
        return self._y_mean + self._y_scale * mean, self._y_scale / np.sqrt(diag)

    def with_fantasy(self, x_new: Any) -> Surrogate:
        """The same surrogate with its own predictions at ``x_new`` added as observations.

        Kernel hyperparameters are kept (no re-optimisation): this is the *kriging believer*
        used to pick a batch, where the predictive variance must drop near points already
        chosen while the mean stays put.

        Parameters
        ----------
        x_new : (m, k) array_like of float
            Coded settings of the fantasised runs.

        Returns
        -------
        Surrogate
        """
        pts = coded_points(x_new, self.n_factors, "x_new")
        mean, _ = self.predict(pts)
        x = np.vstack([self.x, pts])
        y = np.concatenate([self.y, mean])
        noise = None
        if self.noise_var is not None:
            noise = np.concatenate([self.noise_var, np.full(len(pts), np.mean(self.noise_var))])
        fixed = _Fixed(self._gp.kernel_, self._y_mean, self._y_scale)
        return _fit(self.name, (x, y, noise), fixed)


@dataclass(frozen=True)
class _Fixed:
    """Hyperparameters and scaling carried over from an earlier fit."""

    kernel: Any
    y_mean: float
    y_scale: float


def _kernel(k: int, learn_noise: bool) -> Any:
    """Prior kernel in standardised units; bounds chosen for a coded box of width 2."""
    # Length scales from 0.05 (a response that changes within 2.5 % of a range) to 100 (a
    # factor without effect); the constant from 1e-3 to 1e3 times the variance of y.
    base = ConstantKernel(1.0, (1e-3, 1e3)) * Matern(
        length_scale=np.ones(k), length_scale_bounds=(0.05, 100.0), nu=2.5
    )
    if learn_noise:
        return base + WhiteKernel(1e-2, (1e-10, 1.0))
    return base


def _split_white(kernel: Any) -> tuple[Any, float]:
    """A fitted ``C*Matern + White`` as (latent kernel, noise level); noise 0 without White."""
    k2 = getattr(kernel, "k2", None)
    if isinstance(k2, WhiteKernel):
        return kernel.k1, float(k2.noise_level)
    return kernel, 0.0


def _fit(name: str, data: tuple[np.ndarray, np.ndarray, np.ndarray | None],
         fixed: _Fixed | None, seed: int = 0) -> Surrogate:
    """Fit on ``data = (x, y, noise_var)``; with ``fixed``, keep its kernel and scaling."""
    x, y, noise_var = data
    if fixed is None:
        y_mean = float(np.mean(y))
        y_scale = float(np.std(y)) or 1.0
    else:
        y_mean, y_scale = fixed.y_mean, fixed.y_scale
    alpha = 1e-10 if noise_var is None else np.maximum(noise_var / y_scale**2, 1e-10)
    gp = GaussianProcessRegressor(
        kernel=_kernel(x.shape[1], noise_var is None) if fixed is None else fixed.kernel,
        alpha=alpha,
        optimizer="fmin_l_bfgs_b" if fixed is None else None,
        n_restarts_optimizer=3 if fixed is None else 0,
        normalize_y=False,  # standardised here, so that a fantasy keeps the same scale
        random_state=seed,
    )
    with warnings.catch_warnings(), threadpool_limits(limits=1, user_api="blas"):
        # One BLAS thread: these matrices are small, and on a shared machine extra threads
        # spin against each other (a 40 x 40 solve took 11 ms with them, 0.1 ms without).
        # A hyperparameter at its bound (a factor without effect, a noise-free engine) is a
        # legitimate fit, not a failure; the fitted kernel is kept in ``kernel``.
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit(x, (y - y_mean) / y_scale)
    latent, white = _split_white(gp.kernel_)
    scatter = np.sqrt(white) * y_scale if noise_var is None else float(np.sqrt(np.mean(noise_var)))
    return Surrogate(name=name, x=x, y=y, noise_var=noise_var, kernel=str(gp.kernel_),
                     noise_std=float(scatter),
                     log_marginal_likelihood=float(gp.log_marginal_likelihood_value_),
                     _gp=gp, _y_mean=y_mean, _y_scale=y_scale, _latent=latent)


def fit_surrogate(name: str, x: Any, y: Any, *, noise_var: Any = None, seed: int = 0) -> Surrogate:
    """Fit a Gaussian-process surrogate of one response over coded settings.

    Parameters
    ----------
    name : str
        The response's name.
    x : (n, k) array_like of float
        Coded settings of the runs, in [-1, 1] (points outside are allowed but extrapolate).
    y : (n,) array_like of float
        The response at each run, in its unit. NaN rows (failed runs) are dropped.
    noise_var : (n,) array_like of float, optional
        Variance of each ``y`` (unit², e.g. the squared standard error of a replicate mean);
        replaces the learned white-noise term.
    seed : int, optional
        Seed of the optimiser's restarts.

    Returns
    -------
    Surrogate

    Raises
    ------
    InputError
        If shapes disagree, fewer than 3 finite runs remain, or ``noise_var`` is negative.
    """
    pts = coded_points(x)
    obs = np.asarray(y, dtype=float).reshape(-1)
    if len(obs) != len(pts):
        raise InputError(f"response {name}: {len(obs)} values for {len(pts)} settings")
    keep = np.isfinite(obs)
    noise = None
    if noise_var is not None:
        noise = np.asarray(noise_var, dtype=float).reshape(-1)
        if len(noise) != len(pts) or np.any(~(noise[keep] >= 0)):
            raise InputError(f"response {name}: noise_var must be {len(pts)} values >= 0")
        noise = noise[keep]
    if keep.sum() < 3:
        raise InputError(f"response {name}: a surrogate needs >= 3 finite runs; got {keep.sum()}")
    return _fit(name, (pts[keep], obs[keep], noise), None, seed)
