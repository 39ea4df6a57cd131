"""Optimum and verification in rounds: refine the optimum while the verification disagrees.

Round 1 reads the optimum off the response surface of the rsm stage and verifies it on fresh
seeds (:func:`demcal.calibrate.stages.optimize`, :func:`~demcal.calibrate.stages.verification`).
When the verification does not confirm the surface (its mean lies outside the surface's 95 %
prediction interval for the mean of that many runs, Design-Expert's confirmation) or the
target lies outside the piles' own 95 % interval, or (with ``tolerance_percent``, the study's
acceptance criterion) the mean misses the target by more than it, and ``max_rounds``
allows, the next round corrects the surface by the offset the piles measured (their mean
less the surface's prediction at that optimum; pooled with the earlier rounds' while they
agree, :meth:`~demcal.calibrate.rounds.Rounds.offset`; all of it after a round the surface
did not confirm, the share N h / (N h + 1) that the piles' information bears against the
surface's when it did), reads the optimum where the corrected
surface meets the target, starting from the previous one, and verifies it on seeds of its
own: a Newton step on the real test with the surface's slopes. It is what an engineer does by
hand after a failed confirmation ("the model reads 1.4 deg high here: aim 1.4 deg higher"),
and it converges where the quadratic's shape is right locally even when its level is not
(lack of fit, a curved response); refitting the quadratic with the piles as extra rows would
let the 30 design rows hold the surface where it was. The study's answer is the last round's.
"""

from __future__ import annotations

from demcal.calibrate import stages as st
from demcal.summaries import Optimum, Verification
from demcal.summaries.result import ResultRound

__all__ = ["needs_another_round", "round_rows", "run_rounds"]


def needs_another_round(verification: Verification,
                        tolerance_percent: float | None = None) -> bool:
    """Does a verification summary call for a refinement round?

    Yes when every run formed a pile and either the surface's confirmation failed
    (``confirmed`` False), the target lies outside the piles' 95 % interval
    (``target_in_interval`` False), or the mean misses the target by more than
    ``tolerance_percent`` (the study's acceptance criterion, when it sets one). Runs without a
    pile are a problem of the region, not of the surface: no round.
    """
    if verification.n_piles < len(verification.values):
        return False
    rel = verification.relative_error_percent
    missed = tolerance_percent is not None and rel is not None and rel > tolerance_percent
    return missed or verification.confirmed is False or verification.target_in_interval is False


def round_rows(optima: list[Optimum], verifications: list[Verification]) -> list[ResultRound]:
    """One row per round, oldest first: its optimum, prediction, the offset it was aimed by (a
    refinement round) and verification."""
    return [ResultRound.of(o, v) for o, v in zip(optima, verifications, strict=True)]


def run_rounds(ctx: st.Context) -> Verification:
    """Optimize and verify, then refine while :func:`needs_another_round` and the study's
    ``stages.verification.max_rounds`` allow; returns the last verification summary.

    Round ``k`` verifies on seeds ``seed + 10000 k + i``
    (:func:`demcal.calibrate.verify.verification_seed`), so a round never reuses a pile of
    another. Everything is keyed like any other run: a
    resumed study finds every round's runs and re-runs none.
    """
    opts = ctx.study.stages.verification
    while True:
        st.optimize(ctx)
        ver = st.verification(ctx)
        if ctx.rounds.number >= opts.max_rounds or \
                not needs_another_round(ver, opts.tolerance_percent):
            return ver
        ctx.rounds.advance(ctx.results.optimize, ver)
