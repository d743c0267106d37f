"""The size of the foot pose's smooth error, estimated from the stances (type-II maximum
likelihood), instead of a guessed prior (issue 23).

The pose correction's smooth part (:class:`~gc_ocp.estimation.components.pose.PoseCorrection`,
a B-spline per stance) has a Gaussian prior whose width per axis (translation x, y, z [mm],
rotation about x, y, z [deg]) was a guess (2 mm, 1 deg). Across the stances of a fit, its
coefficients are many draws of the same prior, so the width can be estimated: MacKay's fixed
point of the evidence (type-II maximum likelihood), per axis ``a``,

    sigma_a^2  <-  sum_j  c_j^2  /  gamma_a,      gamma_a = sum_j (1 - S_jj / sigma_a^2)

over the axis's coefficients ``c_j`` of every stance, ``S`` the posterior covariance
(Gauss-Newton, at the fit) and ``gamma_a`` the number of coefficients the data determine (a
coefficient the data do not inform has ``S_jj = sigma^2`` and counts 0). The fit is then
repeated with the new widths, warm, until they change by less than :data:`RTOL`. The widths
are then *measured per lab and subject*: what the markers' soft tissue and the rigid-foot
simplification leave in the pose, as far as the forces can tell.

**What it can absorb.** The forces inform the pose; so a width estimated from them also takes in
whatever of the contact model's misfit a smooth pose change can mimic. So the width stays
within what soft tissue can do (:data:`MIN_MM` to :data:`PLAUSIBLE_MM`, :data:`MIN_DEG` to
:data:`PLAUSIBLE_DEG`); a width stopped at the upper limit is flagged: the fit would read part of
the model's error as kinematics, and an effect (a toe joint, a flexible sole, the sole's height)
is the likelier reading.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from gc_ocp.estimation.components.base import per_axis
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.components.sole import SoleCorrection
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions, gauss_newton_inverse, result_at, solve
from gc_ocp.estimation.starts import (
    MINIMA_SE,
    best_of,
    lowest_of,
    physical_distance,
    rescaled_start,
    undecided_minimum,
    with_lls_start,
)
from gc_ocp.stance import StanceData

RTOL = 0.05
"""The rounds stop when no width changes by more than this fraction (a 5 % change of a prior
width moves the fitted parameters by far less than their standard errors)."""

CORRELATION_ATOL = 0.02
"""With ``correlation``, the rounds also wait for the knots' correlation to move by less than
this: near 0.9, 0.02 changes the prior's variance of a stance's mean offset by ~20 %
(``(1 + phi) / (1 - phi)``), twice what the widths' :data:`RTOL` of 5 % does; near 0 by ~4 %."""

MAX_ROUNDS = 8
"""At most this many refits (the bundled trial settles in 4-6)."""

MIN_GAMMA = 1.0
"""An axis whose coefficients the data determine less than one of keeps its width (no
information to estimate it from)."""

PLAUSIBLE_MM = 5.0
"""The pose correction's translation width stops here [mm]: :data:`PLAUSIBLE_DEG`."""
PLAUSIBLE_DEG = 5.0
"""Soft tissue moves skin-mounted foot marker clusters by up to ~5 mm and ~5 deg in walking
(calcaneus and forefoot markers against bone pins: Nester et al. 2007; Leardini et al. 2005;
Chiari et al. 2005). The estimated width stops there, flagged (module doc): without the limit,
three shared labs' fits took 10-25 mm and up to 10 deg (Rajagopal's vertical 24.5 mm), reading
a misfit of the contact model or of the sole's height as kinematics; the contact parameters
then describe a foot displaced by that much."""

SOLE_MIN_MM = SoleCorrection.sigma * 1e3
"""The sole correction's widths are never narrowed below its prior [mm]: :data:`SOLE_PLAUSIBLE_MM`."""
SOLE_PLAUSIBLE_MM = 10.0
"""The sole correction's widths (``sole=True``), one per axis of the foot frame (forward, left,
up), every unit of both feet pooled: the sole's height (calibrated from the markers' height
above a flat sole) and where the units sit along and across the foot (placed from landmarks
centimetres away) are different errors. One width pooled over them shrank the horizontal
offsets of a synthetic foot (true 2.4 mm RMS across the foot, 1.3 mm up) to the vertical's
1.3 mm: 95 % intervals of three of them covered the truth in none of 12 draws.

Each width is *widened* by the data, never narrowed below the component's prior (the
model's ``SoleCorrection.sigma``; by default :data:`SOLE_MIN_MM`, 5 mm: locating the sole
from skin markers over heel and metatarsals).
The offsets are fixed properties of a foot, not draws from a population, and shrinking them
towards the nominal layout moves the law's parameters. On the coverage benchmark (offsets of
up to 8 mm, 1.3 mm RMS up), widths estimated down to 1.1 mm put the exponent's bias at
+0.03, about one standard error, and the units' forces and the offsets covered 88-93 %. At
the 5 mm floor the bias is +0.004, and they cover 98 %. Every real file measured asks for
more than 5 mm, so the floor changes none of them (``docs/quality.md``, *The sole's width per
axis*). Each width stops at 10 mm and is flagged there (a unit a centimetre from where the
landmarks put it, per axis, is beyond what locating the sole from skin markers explains, as
for the pose's widths), unless the model's own prior is wider: that width is the user's."""

MIN_MM = 0.2
"""The pose correction's translation width never goes below this [mm]: :data:`MIN_DEG`."""
MIN_DEG = 0.1
"""Nor below these: markers are reconstructed to ~0.1-0.5 mm, so no lab's smooth pose error is
smaller, and a width near 0 would stop the estimate (a coefficient at 0 stays there)."""


def widths_plausible(sigma_mm, sigma_deg) -> bool:
    """No pose width stopped at the soft tissue's limit (:data:`PLAUSIBLE_MM`,
    :data:`PLAUSIBLE_DEG`; a scalar or one per axis): the width measures a pose error, not a
    misfit of the contact model (module doc). The 0.1 % margin: a width the rounds clipped to
    the limit, read back from ``fit.json`` or a decimal print, counts as at the limit."""
    return bool(
        np.max(sigma_mm) < PLAUSIBLE_MM * 0.999 and np.max(sigma_deg) < PLAUSIBLE_DEG * 0.999
    )


@dataclass(frozen=True)
class PoseScale:
    """The estimated widths [mm] x, y, z and [deg] about x, y, z, the coefficients each axis's
    data determine (``gamma``, of ``n_coefficients``), the rounds' history and the flag."""

    sigma_mm: tuple[float, float, float]
    sigma_deg: tuple[float, float, float]
    gamma: tuple[float, ...]
    n_coefficients: int
    rounds: list[dict]
    n_stances: int
    sole_mm: tuple[float, float, float] | None = None  # the sole's widths x, y, z, when estimated
    sole_gamma: tuple[float, float, float] | None = None
    sole_floor_mm: tuple[float, float, float] | None = None  # the prior the rounds widened
    knot_correlation: float | None = None  # AR(1) per knot, when estimated too
    converged: bool = True  # the last round moved no width by RTOL or more (else MAX_ROUNDS)
    last_change: float = 0.0  # the last round's largest relative move of a width

    @property
    def plausible(self) -> bool:
        """No width stopped at the soft tissue's limit (:data:`PLAUSIBLE_MM`, ``_DEG``,
        :data:`SOLE_PLAUSIBLE_MM`)."""
        return widths_plausible(self.sigma_mm, self.sigma_deg) and self.sole_plausible

    @property
    def sole_plausible(self) -> bool:
        """No sole width stopped at :data:`SOLE_PLAUSIBLE_MM` (a user's prior at or above the
        limit is the user's, not the data's)."""
        if self.sole_mm is None:
            return True
        floor = self.sole_floor_mm or (0.0, 0.0, 0.0)
        return all(
            w < SOLE_PLAUSIBLE_MM * 0.999 or w <= f * 1.001
            for w, f in zip(self.sole_mm, floor, strict=True)
        )

    def message(
        self, advice: str = "run the diagnosis: an unmodelled effect, or the sole's height"
    ) -> str:
        """One line for a summary; ``advice`` ends the at-the-limit warning (a diagnosis says
        where its candidates answer it, not to run itself)."""
        s = (
            f"pose correction's smooth width, estimated over {self.n_stances} stances (type-II ML, "
            f"{len(self.rounds)} rounds): translation x/y/z "
            + "/".join(f"{v:.1f}" for v in self.sigma_mm)
            + " mm, rotation "
            + "/".join(f"{v:.1f}" for v in self.sigma_deg)
            + " deg"
        )
        if self.sole_mm is not None:
            s += "; sole correction's width x/y/z " + "/".join(f"{v:.1f}" for v in self.sole_mm)
            s += " mm"
        if self.knot_correlation is not None:
            s += f"; its coefficients correlated {self.knot_correlation:.2f} one knot apart"
        if not self.converged:
            s += (
                f"; not converged in {len(self.rounds)} rounds (the last moved a width by "
                f"{self.last_change:.0%}): the widths and SEs are the last round's"
            )
        if not self.plausible:
            s += (
                f"; the forces ask for more than soft tissue moves a foot (stopped at "
                f"{PLAUSIBLE_MM:g} mm, {PLAUSIBLE_DEG:g} deg"
                + ("" if self.sole_mm is None else f", sole {SOLE_PLAUSIBLE_MM:g} mm")
                + f"): the contact model misfits these stances ({advice})"
            )
        return s

    def to_json(self) -> dict:
        return {
            "sigma_mm": list(self.sigma_mm),
            "sigma_deg": list(self.sigma_deg),
            "gamma": list(self.gamma),
            "n_coefficients": self.n_coefficients,
            "n_stances": self.n_stances,
            "plausible": self.plausible,
            "converged": self.converged,
            "last_change": self.last_change,  # what "converged" read (RTOL)
            "rounds": self.rounds,
            "message": self.message(),
            **(
                {}
                if self.sole_mm is None
                else {
                    "sole_mm": list(self.sole_mm),
                    "sole_gamma": list(self.sole_gamma),
                    # the prior the rounds widened: a width at the limit that is the user's
                    # prior is not flagged ("plausible" reads it)
                    **(
                        {}
                        if self.sole_floor_mm is None
                        else {"sole_floor_mm": list(self.sole_floor_mm)}
                    ),
                }
            ),
            **(
                {} if self.knot_correlation is None else {"knot_correlation": self.knot_correlation}
            ),
        }


def _axis_columns(problem, name: str, kind: str) -> list[np.ndarray]:
    """Per axis (x, y, z), the columns of the ``(name, label, kind)`` coefficient blocks
    (stored 3 x K column-major: x, y, z of knot 0, then knot 1, ...)."""
    out: list[list[int]] = [[], [], []]
    for s in problem.variables.specs:
        if s.key[0] == name and s.key[-1] == kind:
            for j in range(s.size):
                out[j % 3].append(s.start + j)
    return [np.asarray(o, int) for o in out]


def _posterior_covariance(problem, x: np.ndarray) -> np.ndarray:
    """The Gauss-Newton posterior covariance at ``x`` (stored units: a prior variable's prior
    variance is 1)."""
    _, J = problem.data_jacobian(x)
    return gauss_newton_inverse((J.T @ J).toarray() + np.diag(problem.prior_weights**2))


def _posterior_variances(problem, x: np.ndarray) -> np.ndarray:
    """The diagonal of :func:`_posterior_covariance`."""
    return np.diag(_posterior_covariance(problem, x))


MAX_KNOT_CORRELATION = 0.98
"""The estimated correlation of neighbouring knots stops here: at 1 a stance's correction is
one rigid offset and the correlation matrix is singular."""


def ar1_knot_correlation(
    phi: float, pose: PoseCorrection, stances: list
) -> tuple[float, ...] | None:
    """``knot_correlation`` of an AR(1) sequence with ``phi`` one knot apart (None for ``phi``
    0: independent coefficients), long enough for four times the longest of ``stances`` and at
    least 256 knots: a held-out or other stance built with it later may be longer, and a
    sequence cut short (zeros beyond) need not be a valid correlation."""
    if phi <= 0.0:
        return None
    K = max(pose.basis(st.time)[0].shape[1] for st in stances)
    return tuple(float(phi**k) for k in range(max(4 * K, 256)))


def knot_correlation_update(problem, x: np.ndarray, pose: PoseCorrection, S: np.ndarray) -> float:
    """The EM step for the correlation of neighbouring coefficients of the pose correction's
    smooth part (an AR(1) prior along each stance): the expected second moment of the
    coefficients in units of their widths, ``L (z z^T + S_zz) L^T`` (``z`` the stored variables,
    ``S`` the posterior covariance, ``L`` the prior's correlation factor), its mean lag-1 product
    over its mean square, pooled over every stance, part and axis; clipped to [0,
    :data:`MAX_KNOT_CORRELATION`]. Under independent coefficients it is ~0 (the posterior's
    smoothing is undone by ``S``); a drift that sits in the lowest frequencies (an offset and a
    trend per stance) takes it to ~0.9 (``docs/quality.md``, *The lead: a pose prior whose
    variance sits in the low frequencies*)."""
    spec = {s_.key: s_ for s_ in problem.variables.specs}
    m0 = m1 = 0.0
    for st in problem.stances:
        for part in ("trans", "rot"):
            sp = spec[(pose.name, st.label, part)]
            K = sp.size // 3
            if K < 2:
                continue
            L = pose.correlation_factor(K)
            for a in range(3):
                cols = sp.start + a + 3 * np.arange(K)
                M = L @ (np.outer(x[cols], x[cols]) + S[np.ix_(cols, cols)]) @ L.T
                m0 += np.trace(M) / K
                m1 += np.trace(M, offset=1) / (K - 1)
    return float(np.clip(m1 / m0, 0.0, MAX_KNOT_CORRELATION)) if m0 > 0 else 0.0


def _width_step(old: float, x: np.ndarray, Sd: np.ndarray, cols, lo: float, hi: float) -> tuple:
    """``(width, gamma)``: the fixed-point step (module doc) for one width ``old`` shared by the
    coefficients ``cols`` (stored in units of ``old``), clipped to ``[lo, hi]``; a group the
    data determine less than :data:`MIN_GAMMA` of keeps ``old``."""
    g = float(np.sum(1.0 - Sd[cols]))
    z2 = float(np.sum(x[cols] ** 2))
    w = float(old * np.sqrt(z2 / g)) if g >= MIN_GAMMA else float(old)
    return float(np.clip(w, lo, hi)), g


def mackay_update(
    problem, x: np.ndarray, pose: PoseCorrection, Sd: np.ndarray | None = None
) -> tuple[tuple, tuple, tuple, int]:
    """One fixed-point step (module doc) at the fit ``x`` of ``problem``: the new widths
    (mm, deg), ``gamma`` per axis and the coefficients per axis (``Sd``: the posterior
    variances, :func:`_posterior_variances`, when already computed)."""
    Sd = _posterior_variances(problem, x) if Sd is None else Sd
    widths, gammas, n = [], [], 0
    for kind, old in (("trans", pose.sigma_mm), ("rot", pose.sigma_deg)):
        old = per_axis(old)
        for a, cols in enumerate(_axis_columns(problem, pose.name, kind)):
            n = cols.size
            lo, hi = (MIN_MM, PLAUSIBLE_MM) if kind == "trans" else (MIN_DEG, PLAUSIBLE_DEG)
            w, g = _width_step(old[a], x, Sd, cols, lo, hi)
            widths.append(w)
            gammas.append(g)
    return tuple(widths[:3]), tuple(widths[3:]), tuple(gammas), n


def sole_update(problem, x: np.ndarray, sole: SoleCorrection, Sd: np.ndarray, floor=None) -> tuple:
    """The same step for the sole correction's widths, one per axis of the foot frame (x, y,
    z; every unit of both feet pooled): ``(widths [m], gamma)``, each a 3-tuple. ``floor``
    [m] (a scalar or one per axis): the prior the rounds started from, below which no width
    goes (:data:`SOLE_MIN_MM`; default ``sole.sigma``); the upper limit is
    :data:`SOLE_PLAUSIBLE_MM`, or the floor where a user's prior is wider."""
    cols = np.concatenate(
        [
            np.arange(s.start, s.start + s.size)
            for s in problem.variables.specs
            if s.key[0] == sole.name
        ]
    )
    old = per_axis(sole.sigma)
    lo = per_axis(sole.sigma if floor is None else floor)
    widths, gammas = [], []
    for a in range(3):  # a unit's block holds its x, y, z (prior_variable, 3 per unit)
        hi = max(SOLE_PLAUSIBLE_MM * 1e-3, lo[a])
        w, g = _width_step(old[a], x, Sd, cols[a::3], lo[a], hi)
        widths.append(w)
        gammas.append(g)
    return tuple(widths), tuple(gammas)


def estimate_pose_scale(
    data: list[StanceData],
    model: tuple,
    result: EstimationResult,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
    refit: Callable[[object, np.ndarray, bool], EstimationResult] | None = None,
    sole: bool = False,
    covariance: bool = True,
    correlation: bool = False,
) -> tuple[tuple, EstimationResult, PoseScale | None]:
    """The model with the pose correction's widths estimated on ``data`` (module doc), its fit
    (warm-started from ``result``, the fit with the current widths) and the estimate; the input
    unchanged (and None) when the model has no pose correction. ``refit(problem, x0,
    covariance)``: each round's warm refit (default: Ipopt, :func:`~gc_ocp.estimation.solve.solve`; a benchmark
    passes another solver to time the same rounds). ``sole``: estimate the sole correction's
    width in the same rounds (:func:`sole_update`). ``covariance``: the returned fit carries its
    covariance (False: a caller that keeps only the widths); either way only the last round's
    refit computes it (whether the round is the last is known before its refit, from the
    widths' change). ``correlation``: estimate the correlation of neighbouring coefficients in
    the same rounds too (:func:`knot_correlation_update`; an AR(1) ``knot_correlation``; the
    rounds stop when it moves by less than :data:`CORRELATION_ATOL`)."""
    say = progress or (lambda s: None)
    if refit is None:

        def refit(prob, x0, cov):
            return solve(prob, options, x0=x0, covariance=cov, warm=True)

    pose = next((c for c in model if isinstance(c, PoseCorrection)), None)
    if pose is None:
        return model, result, None
    sole_c = next((c for c in model if isinstance(c, SoleCorrection)), None) if sole else None
    if sole_c is not None and sole_c.fixed is not None:
        sole_c = None
    rounds = []
    sole_w = sole_g = None
    # the sole's widths are widened from the prior the model came with, never narrowed
    sole_floor = None if sole_c is None else per_axis(sole_c.sigma)
    phi = float(pose.knot_correlation[1]) if correlation and pose.knot_correlation else 0.0
    prob = build_estimation(data, model, weights)
    # the returned fit's seconds and iterations are the totals of the fit, as best_of's are
    total_s, total_it = result.seconds, result.iterations
    for k in range(MAX_ROUNDS):
        S = _posterior_covariance(prob, result.x)
        Sd = np.diag(S)
        mm, deg, gamma, n = mackay_update(prob, result.x, pose, Sd)
        old = np.r_[per_axis(pose.sigma_mm), per_axis(pose.sigma_deg)]
        change = float(np.max(np.abs(np.r_[mm, deg] / old - 1.0)))
        pose = replace(pose, sigma_mm=mm, sigma_deg=deg)
        if correlation:
            new_phi = knot_correlation_update(prob, result.x, pose, S)
            # a move of CORRELATION_ATOL counts as a width's change of RTOL
            change = max(change, abs(new_phi - phi) / CORRELATION_ATOL * RTOL)
            phi = new_phi
            pose = replace(pose, knot_correlation=ar1_knot_correlation(phi, pose, data))
        new = {PoseCorrection: pose}
        if sole_c is not None:
            sole_w, sole_g = sole_update(prob, result.x, sole_c, Sd, sole_floor)
            change = max(change, float(np.max(np.abs(np.divide(sole_w, sole_c.sigma) - 1.0))))
            sole_c = replace(sole_c, sigma=sole_w)
            new[SoleCorrection] = sole_c
        model = tuple(new.get(type(c), c) for c in model)
        # the rounds differ in widths only: one solver serves them (``like``)
        prob = build_estimation(data, model, weights, like=prob)
        last = change < RTOL or k == MAX_ROUNDS - 1
        result = refit(prob, rescaled_start(result, prob), covariance and last)
        total_s, total_it = total_s + result.seconds, total_it + result.iterations
        row = {
            "sigma_mm": list(mm),
            "sigma_deg": list(deg),
            "objective": result.objective,
            "iterations": result.iterations,
        }
        if sole_w is not None:
            row["sole_mm"] = [w * 1e3 for w in sole_w]
        if correlation:
            row["knot_correlation"] = phi
        rounds.append(row)
        say(
            f"pose width round {k + 1}: {', '.join(f'{v:.2f}' for v in mm)} mm, "
            f"{', '.join(f'{v:.2f}' for v in deg)} deg"
            + ("" if sole_w is None else f", sole {'/'.join(f'{w * 1e3:.2f}' for w in sole_w)} mm")
            + (f", knots correlated {phi:.2f}" if correlation else "")
            + f"; J = {result.objective:.1f}, {result.iterations} iterations"
        )
        if last:
            break
    result.seconds, result.iterations = total_s, total_it
    est = PoseScale(
        mm,
        deg,
        gamma,
        n,
        rounds,
        len(data),
        sole_mm=None if sole_w is None else tuple(w * 1e3 for w in sole_w),
        sole_gamma=sole_g,
        sole_floor_mm=None if sole_floor is None else tuple(float(v) * 1e3 for v in sole_floor),
        knot_correlation=phi if correlation else None,
        converged=change < RTOL,
        last_change=change,
    )
    return model, result, est


def lowest_with_widths(
    data: list[StanceData],
    model: tuple,
    result: EstimationResult,
    others: list,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
    flags: bool = True,
    **rounds,
) -> tuple[tuple, EstimationResult, PoseScale | None, list[str], list[dict]]:
    """:func:`estimate_pose_scale` from the multi-start's winner ``result``, with the fit's
    minimum chosen on the problem it returns: the starts that lost (``others``, filled by
    :func:`~gc_ocp.estimation.starts.best_of`, compared there at the prior's widths) solved at
    the widths estimated from the winner (:func:`~gc_ocp.estimation.starts.lowest_of`); if one
    ends lower, the widths are estimated again from it, that fit is returned, and the other
    minima are solved once more at its widths. ``rounds``: :func:`estimate_pose_scale`'s
    keywords (``sole``, ``covariance``, ``correlation``). Also returned: notes for
    ``fit.json``'s checks (another start's minimum kept, with both objectives) and, with
    ``flags``, the fit's ``minimum_undecided`` flags: every other minimum at the returned
    widths that the plates do not prefer the kept one to, far from it in SE units
    (:func:`~gc_ocp.estimation.starts.undecided_minimum`)."""
    say = progress or (lambda s: None)
    model, res, scale = estimate_pose_scale(data, model, result, weights, options, say, **rounds)
    if scale is None or not others:
        return model, res, scale, [], []
    say("comparing the other starts at the estimated widths")
    prob = build_estimation(data, model, weights)
    lower, solved, (spent_s, spent_it) = lowest_of(prob, res, others, options, say)
    # the returned fit's seconds and iterations: every start, round and comparison (best_of's)
    notes = []
    if lower is not None:
        j0, j1 = float(res.objective), float(lower.objective)
        what = next(w for w, r in solved if r is lower)
        first = ("the start that won at the prior's widths", res)
        lower.seconds, lower.iterations = res.seconds + spent_s, res.iterations + spent_it
        model, res, scale = estimate_pose_scale(data, model, lower, weights, options, say, **rounds)
        notes.append(
            f"the fit's minimum is the one {what} reached: at the widths estimated from the "
            f"start that won at the prior's widths it ends at J = {j1:.2f} against that start's "
            f"{j0:.2f}, and the widths estimated again from it end at J = {res.objective:.2f} "
            "(the objective has several minima; the one kept is the lowest of the problem the "
            "fit returns)"
        )
        # the other minima at the returned widths (no second switch: the choice was made)
        say("the other minima at the widths estimated again")
        prob = build_estimation(data, model, weights, like=prob)
        rest = [first] + [(w, r) for w, r in solved if r is not lower]
        _, solved, (spent_s, spent_it) = lowest_of(prob, res, rest, options, say)
    res.seconds, res.iterations = res.seconds + spent_s, res.iterations + spent_it
    if not flags or not solved:
        return model, res, scale, notes, []
    at = res if res.covariance is not None else result_at(prob, res.x)
    found, near = [], []  # one flag per place: two starts that stopped within 1 SE of each
    for what, r in solved:  # other (objectives apart by more than the solver's tolerance) are
        f = undecided_minimum(prob, at, r, what)  # one minimum reached twice
        if f is not None and all(physical_distance(prob, at, r.x, x) > MINIMA_SE / 2 for x in near):
            found.append(f)
            near.append(r.x)
    return model, res, scale, notes, found


def with_estimated_width(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[tuple, PoseScale | None]:
    """``model`` with its pose correction's widths estimated on ``data`` (fitted from the one
    start path, then :func:`estimate_pose_scale`), and the estimate; ``model`` unchanged (and
    None) without a pose correction. The diagnosis's nuisance then has the size these stances
    ask for (``docs/quality.md``)."""
    if not any(isinstance(c, PoseCorrection) for c in model):
        return model, None
    others: list = []
    start = best_of(
        data, with_lls_start(model, data), weights, options, covariance=False, others=others
    )
    fitted, _, scale, _, _ = lowest_with_widths(
        data, model, start, others, weights, options, progress, flags=False, covariance=False
    )
    pose = next(c for c in fitted if isinstance(c, PoseCorrection))
    return tuple(pose if isinstance(c, PoseCorrection) else c for c in model), scale


__all__ = [
    "ar1_knot_correlation",
    "knot_correlation_update",
    "widths_plausible",
    "PoseScale",
    "estimate_pose_scale",
    "lowest_with_widths",
    "mackay_update",
    "with_estimated_width",
]
