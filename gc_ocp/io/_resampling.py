"""Samples that are a polynomial interpolation of a lower rate: the pure numerics behind the
``native_rate_hz`` of :mod:`gc_ocp.io.processing` (NumPy only).

Between two knots a degree-p polynomial has a vanishing (p+1)-th difference; a stencil of p+2
samples is non-zero only when it straddles a knot. Interpolating every R-th sample thus leaves
at most p+1 of every R phases of the sample index with a non-zero (p+1)-th difference (hold:
p = 0, linear: 1, quadratic: 2, cubic spline: 3). Measured data (noise) have no such phases.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

DEGREES = ("hold", "linear", "quadratic", "cubic")
"""Names of the polynomial degrees 0-3."""
MAX_FACTOR = 32
"""Largest interpolation factor tested (e.g. 60 Hz markers -> 1920 Hz)."""
MIN_QUIET_SHARE = 0.3
"""Share of vanishing (p+1)-th differences below which degree p is not tried (with a factor
R >= 2 and p + 1 non-zero phases, at least 1 - (p+1)/R of them vanish: 0.33 for cubic at R = 6;
white noise has ~none)."""


MIN_KNOT_SHARE = 0.5
"""Share of non-vanishing differences the non-vanishing phases must hold (averaged over them):
a knot's stencil straddles the change of the interpolating polynomial, non-zero on noisy data
at nearly every knot; a strongly low-passed signal whose differences all vanish but for a few
at its sharpest peak (3 of 3938 on a plate low-passed at 10 Hz: read as a cubic interpolation
from 1080 / 32 Hz before) has these few at any phases, not at every knot."""


def decimals_quantum(x: np.ndarray) -> float:
    """Step of the decimal numbers ``x`` was written with (10^-k for the smallest k <= 9 that
    makes every value a whole number of steps, to 1e-6 of a step), 0 when none fits (binary
    floats: C3D, or computed)."""
    x = x[np.isfinite(x)][:2000]
    for k in range(10):
        s = x * 10.0**k
        if np.all(np.abs(s - np.round(s)) <= 1e-6 + 1e-12 * np.abs(s)):
            return 10.0**-k
    return 0.0


def interpolation_factor(segments: Sequence[tuple[int, np.ndarray]]) -> tuple[int, int] | None:
    """``(factor R, degree p)`` when the samples are a degree-p polynomial interpolation of
    every R-th sample (module docstring), ``None`` when no ``R <= MAX_FACTOR`` fits.

    ``segments``: ``(index of the first sample, samples)`` of the valid stretches of one signal
    (the phase is that of the absolute sample index). A difference "vanishes" below the rounding
    of the stored numbers: ``2^(p+1)`` decimal steps (:func:`decimals_quantum`; for binary data a
    float32 step at the largest value) plus 1e-6 of the largest difference. Among the R whose
    phases all vanish but at most p + 1, the one with the largest share of vanishing phases wins
    (multiples of R tie with R: the smallest wins); the lowest such degree p is returned."""
    values = [np.asarray(s, dtype=float) for _, s in segments]
    allx = np.concatenate(values) if values else np.zeros(0)
    if allx.size < 4 * MAX_FACTOR:
        return None
    quantum = decimals_quantum(allx) or 2.0**-23 * float(np.max(np.abs(allx)))
    for p in range(len(DEGREES)):
        idx = np.concatenate(
            [a + np.arange(x.size - p - 1) for (a, _), x in zip(segments, values, strict=True)]
        )
        val = np.concatenate([np.abs(np.diff(x, p + 1)) for x in values])
        if val.size == 0 or not np.any(val > 0):
            continue
        small = val <= 2.0 ** (p + 1) * quantum + 1e-6 * float(val.max())
        if small.mean() < MIN_QUIET_SHARE:
            continue
        best = (0.0, 0)
        for r in range(p + 2, MAX_FACTOR + 1):
            small_share = np.array([small[idx % r == k].mean() for k in range(r)])
            quiet = small_share == 1.0
            share = float(quiet.mean())
            # the other phases straddle a knot at (almost) every one of their samples
            knots = float(np.mean(1.0 - small_share[~quiet])) if (~quiet).any() else 0.0
            if (
                quiet.sum() >= r - (p + 1)
                and knots >= MIN_KNOT_SHARE
                and best[0] + 1e-9 < share < 1.0
            ):
                best = (share, r)
        if best[1]:
            return best[1], p
    return None
