"""Starting points and restarts of the estimator: the seed's linear least squares as the
contact law's start, prior-width continuation, several starts keeping the lowest objective, warm
starts from a result, and a model frozen at a result for a held-out evaluation.

Every caller that fits (``gc_ocp.fit``, the diagnosis's folds, the benchmarks) starts the same
way: :func:`with_lls_start` on the stances it fits, and nothing else (no held-out stance can reach
the start). This module imports nothing that reads files (the core of :mod:`gc_ocp.estimation`
never imports :mod:`gc_ocp.io`; ``tests/test_package.py`` checks it).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import scipy.sparse as sparse
from scipy.optimize import least_squares

from gc_ocp.contact.lls import fit_stiffness_lls
from gc_ocp.errors import InputError, RankError, SolveError
from gc_ocp.estimation.flags import flag, variable_key, without_se
from gc_ocp.estimation.problem import EstimationProblem, Weights, build_estimation, configured
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions, hac_bandwidth, result_at, solve
from gc_ocp.stance import StanceData
from gc_ocp.trial import SIDES

TYPICAL_DEPTH = 0.005
"""Typical unit penetration [m] used to convert the LLS stiffness (n = 1) to the initial
stiffness of an exponent-n law: k_n = k_1 * TYPICAL_DEPTH**(1 - n) (equal force at that depth)."""


def lls_k0(stances: list, n0: float, quiet: bool = False) -> dict | None:
    """Initial per-unit stiffness of an exponent-``n0`` law from the seed's linear least squares
    on ``stances``: negative or tiny LLS stiffnesses are raised to a floor (10 % of the median
    positive one, at least 1e3 N/m), then converted with :data:`TYPICAL_DEPTH`. ``None`` (with a
    warning, unless ``quiet``: a fold's or a replicate's fit, where a unit that never touches
    the fold's stances is expected and the fit of all stances has said it) when the LLS is rank
    deficient. A foot without stances gets the floor (the model declares both feet)."""
    st0 = stances[0]
    try:
        res = fit_stiffness_lls(
            list(stances), st0.body_weight, st0.body_weight * (st0.height or 1.7)
        )
    except RankError as e:
        if quiet:
            return None
        warnings.warn(
            f"LLS initialisation not possible ({e}); starting from a uniform stiffness.",
            stacklevel=2,
        )
        return None
    out = {}
    k_all = np.array([v for s in res.k.values() for v in s.values()])
    floor = max(np.median(k_all[k_all > 0]) * 0.1, 1e3) if np.any(k_all > 0) else 1e4
    units = {st.side: st.layout.units for st in stances}
    for side in SIDES:
        out[side] = {
            u: float(max(res.k.get(side, {}).get(u, floor), floor) * TYPICAL_DEPTH ** (1 - n0))
            for u in units.get(side, next(iter(units.values())))
        }
    return out


def with_lls_start(model: tuple, stances: list, quiet: bool = False) -> tuple:
    """``model`` with its contact law (the component with ``with_initial_k``) started at the
    seed's linear least squares on ``stances`` (:func:`lls_k0`), converted to the exponent the
    law has once the model is configured (a stiffness exponent fixes the law's own at 1: its
    stiffness variable is then in N/m, whatever the law's ``n`` was given as)."""
    law = next((c for c in model if hasattr(c, "with_initial_k")), None)
    if law is None:
        return model
    n0 = next(c for c in configured(model) if hasattr(c, "with_initial_k")).n.value_for(SIDES[0])
    k0 = lls_k0(stances, float(n0), quiet)
    return tuple(c.with_initial_k(k0) if c is law else c for c in model)


CONTINUATION = (0.2, 0.5, 1.0)
"""Prior-width continuation: the sole and pose priors first 0.2x, then 0.5x, then 1x their width,
each stage warm-started from the previous one (trusting the markers more at first)."""

STRATEGIES = ((1.0,), CONTINUATION)
"""Continuation schedules tried by :func:`fit` (with one more start, a trust-region warm-up:
:func:`best_of`'s ``trust_region``); the lowest objective wins. The problem is not convex: on the
bundled example a single solve from the LLS start ends at J = 655 and the continuation at 599; on
the Rajagopal trial the single solve ends at 530 and the continuation at 682."""


def rescaled_start(
    prev: EstimationResult, prob, neutral: bool = False, under: np.ndarray | None = None
) -> np.ndarray:
    """Warm start for ``prob`` from the result ``prev``, matching variables by key (prior
    variables are stored in units of their sigma, so they are rescaled); the variables ``prev``
    lacks keep ``prob``'s start (``neutral``: 0, the stored neutral value; ``under``: that point
    of ``prob``, to lay several results over one another)."""
    if under is not None:
        x0 = np.array(under, float)
    else:
        x0 = np.zeros(prob.x0.size) if neutral else prob.x0.copy()
    old = {s.key: s for s in prev.variables}
    for spec in prob.variables.specs:
        o = old.get(spec.key)
        if o is None or o.size != spec.size:
            continue
        z = prev.x[o.slice]
        if spec.kind == "prior":
            z = z * o.scale / spec.scale
        x0[spec.slice] = np.clip(z, spec.lb, spec.ub)
    return x0


def neutral_points(prev: EstimationResult, prob) -> tuple[np.ndarray, np.ndarray]:
    """The two points of ``prob`` where a model that extends ``prev``'s may reproduce it exactly:
    ``prev``'s variables as in :func:`rescaled_start` and the new ones at their stored 0, then
    at their initial values (an effect is neutral at one of the two: a damping at 0, a clock
    offset at 0; :func:`~gc_ocp.diagnosis.onestep.nested_point` and
    :func:`~gc_ocp.diagnosis.compare.fit_fold` test which, if either, does)."""
    x = rescaled_start(prev, prob)
    old = {s.key for s in prev.variables}
    zero = x.copy()
    for s in prob.variables.specs:
        if s.key not in old:
            zero[s.slice] = np.clip(0.0, s.lb, s.ub)
    return zero, x


def estimate(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    continuation: tuple[float, ...] = CONTINUATION,
    progress: Callable[[str], None] | None = None,
    covariance: bool = True,
) -> EstimationResult:
    """Solve ``model`` on ``data`` with prior-width continuation (see :data:`CONTINUATION`).

    The returned result is the last stage's (the requested priors); its ``seconds`` and
    ``iterations`` are the totals over all stages. The covariance is computed for the last stage
    only, and not at all with ``covariance=False``.
    """
    return _estimate(data, model, weights, options, continuation, progress, covariance)[0]


def _estimate(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None,
    options: IpoptOptions | None,
    continuation: tuple[float, ...],
    progress: Callable[[str], None] | None,
    covariance: bool,
    like: EstimationProblem | None = None,
):
    """:func:`estimate`, and the last stage's problem (the one its result is a point of).
    ``like``: a problem of the same stances that may differ from the stages' only in prior
    widths (one solver for all, :func:`~gc_ocp.estimation.problem.build_estimation`)."""
    say = progress or (lambda s: None)
    steps = continuation if any(c.has_prior_scale for c in model) else (1.0,)
    prev = None
    total_s, total_it = 0.0, 0
    res = None
    for f in steps:
        m = tuple(
            c.with_prior_scale(f) if hasattr(c, "with_prior_scale") and f != 1.0 else c
            for c in model
        )
        # the stages differ in prior widths only: one solver serves them (``like``)
        prob = build_estimation(data, m, weights, like=like)
        like = prob
        x0 = rescaled_start(prev, prob) if prev is not None else None
        last = f == steps[-1]
        res = solve(
            prob, options, x0=x0, raise_on_failure=last, covariance=covariance and last, warm=True
        )
        total_s += res.seconds
        total_it += res.iterations
        say(f"  prior scale {f:g}: {_ended_text(res).strip()}")
        prev = res
    res.seconds, res.iterations = total_s, total_it
    return res, prob


def _ended_text(res) -> str:
    """A progress line's account of one solve: status, iterations, objective."""
    return f"  {res.status}, {res.iterations} iterations, J = {res.objective:.1f}"


def best_of(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    strategies: tuple[tuple[float, ...], ...] = STRATEGIES,
    progress: Callable[[str], None] | None = None,
    start: EstimationResult | None = None,
    covariance: bool = True,
    others: list | None = None,
    trust_region: bool = False,
) -> EstimationResult:
    """Run :func:`estimate` once per continuation schedule in ``strategies`` and keep the result
    with the lowest objective (``seconds``/``iterations`` are totals over every start). A start
    that fails is skipped; if all fail, the last error is raised. ``others``: a list the starts
    that did not win are appended to, ``(what, result)``, for a caller that compares them again
    on the problem it returns (:func:`lowest_of`: the fit's widths are estimated after this).

    start: a result of a model this one extends (e.g. the base, for base + an effect): one more
    start from its solution (variables matched by key, the new ones at their initial values,
    which for an effect is its neutral value), so that the extended model ends at least as low
    as the model it extends whenever that start converges. With censored stances (a plate
    zeroed below a threshold) and ``strategies``, the same model fitted with the zeros taken as
    data is one more start (see the code's comment). ``covariance``: the returned result
    carries its covariance, computed for the winning start only (every start is solved
    without it; the same function of the winner's problem and point). ``trust_region``: one
    more start, Ipopt from a few trust-region steps (:func:`trust_region_point`), solved last
    (on equal objectives the earlier starts win)."""
    say = progress or (lambda s: None)
    best, total_s, total_it, err = None, 0.0, 0, None
    starts = [] if start is None else [("the given result", start)]
    if strategies and any(st.censor_below > 0 for st in data):
        # a censored sample's residual has a kink at the threshold; from the LLS start the
        # solver can settle in a worse minimum than the same problem reached from the fit that
        # treats the zeros as data (Plug-in Gait example: J 655 against 599), so that fit is
        # one more start (no kink; every censored sample then only gets cheaper)
        say("start: the fit without censoring")
        plain = [replace(st, censor_below=0.0) for st in data]
        try:
            p = best_of(
                plain,
                model,
                weights,
                options,
                strategies,
                lambda line: say("  " + line),  # its own starts, indented under this one
                start,
                covariance=False,
                trust_region=trust_region,
            )
            total_s += p.seconds
            total_it += p.iterations
            starts.append(("the fit without censoring", p))
        except SolveError as e:
            err = e
    prob = None  # the starts' problems differ in prior widths only: one solver (``like``)
    ended = []  # (what, result, problem) of every start that converged
    for what, s0 in starts:
        say(f"start: from {what}")
        try:
            prob = build_estimation(data, model, weights, like=prob)
            r = solve(prob, options, x0=rescaled_start(s0, prob), covariance=False)
            total_s += r.seconds
            total_it += r.iterations
            say(_ended_text(r))
            ended.append((f"the start from {what}", r, prob))
        except SolveError as e:
            err = e
            if e.result is not None:
                total_s, total_it = total_s + e.result.seconds, total_it + e.result.iterations
    for steps in strategies:
        scales = ", ".join(f"{f:g}" for f in steps)
        say(f"start: prior scales {scales}")
        try:
            r, prob = _estimate(data, model, weights, options, steps, say, False, like=prob)
        except SolveError as e:
            err = e
            if e.result is not None:
                total_s, total_it = total_s + e.result.seconds, total_it + e.result.iterations
            continue
        total_s += r.seconds
        total_it += r.iterations
        ended.append((f"the start of prior scales {scales}", r, prob))
    if trust_region:
        say("start: a trust-region warm-up")
        try:
            prob = build_estimation(data, model, weights, like=prob)
            r = solve(prob, options, x0=trust_region_point(prob), covariance=False, warm=True)
            total_s += r.seconds
            total_it += r.iterations
            say(_ended_text(r))
            ended.append(("the start after a trust-region warm-up", r, prob))
        except SolveError as e:
            err = e
            if e.result is not None:
                total_s, total_it = total_s + e.result.seconds, total_it + e.result.iterations
    if not ended:
        if err is None:
            raise InputError(
                "best_of was given nothing to solve: no continuation schedule (strategies=()) "
                "and no start; give strategies (default STRATEGIES) or start=a result"
            )
        raise err
    # the first of equal objectives wins (the order above: a given start, then the schedules)
    won = min(range(len(ended)), key=lambda i: ended[i][1].objective)
    _, best, best_prob = ended[won]
    if others is not None:  # one of each minimum: a start that ended where another did is not
        for what, r, _ in sorted(ended, key=lambda e: e[1].objective):  # compared again
            kept = [best] + [o for _, o in others]
            if all(not _same_minimum(r.objective, o.objective) for o in kept):
                others.append((what, r))
    if covariance and best.covariance is None:
        # every start was solved without it: only the winner's is computed (the same function
        # of the problem and the point, so the same result as computing it in its solve)
        best = result_at(best_prob, best.x, status=best.status, success=best.success)
    best.seconds, best.iterations = total_s, total_it
    return best


TRUST_REGION_STEPS = 5
"""Residual evaluations of the trust-region warm-up (:func:`trust_region_point`). Measured on
the bundled trial at the prior's widths (2026-12-03): Ipopt from the problem's start ends at
J = 635.1, from the point after 5, 10, 20, 40 or 80 trust-region evaluations at 577.8 every
time (0.14 s for 5 on one core): the first few bounded steps already choose the basin."""


def trust_region_point(problem: EstimationProblem, steps: int = TRUST_REGION_STEPS) -> np.ndarray:
    """A start for Ipopt: ``steps`` residual evaluations of a bounded trust-region least-squares
    method (scipy's ``trf``, its sub-problems by LSMR on the exact sparse Jacobian of the
    problem's residuals, data and priors, from the per-frame compiled Jacobians
    :meth:`~gc_ocp.estimation.problem.EstimationProblem.data_jacobian`) from the problem's start. Ipopt's first line-search
    Newton steps from the start can cross into a worse basin than the small, bounded steps of a
    trust region take: on the bundled trial the two starts of :data:`STRATEGIES` end at J 635
    at the prior's widths and Ipopt from this point at 578 (data cost 351 against 292); on
    Rajagopal 696 against 671; on Gait2392 it ends higher (352 against 323) and the other
    starts win (``docs/estimation.md``, *Starts*)."""
    lb, ub = np.asarray(problem.lbx, float).ravel(), np.asarray(problem.ubx, float).ravel()
    x0 = np.clip(np.asarray(problem.x0, float).ravel(), lb, ub)
    prior_rows = sparse.diags(np.asarray(problem.prior_weights, float), format="csr")

    def residuals(x):  # data, then priors: 1/2 |.|^2 is the problem's objective
        return np.concatenate([problem.data_residuals(x), problem.prior_residuals(x)])

    def jacobian(x):  # the per-frame compiled Jacobians (no symbolic Jacobian of the graph)
        return sparse.vstack([problem.data_jacobian(x)[1], prior_rows], format="csr")

    res = least_squares(
        residuals,
        x0,
        jac=jacobian,
        method="trf",
        bounds=(lb, ub),
        tr_solver="lsmr",
        max_nfev=steps,
    )
    return np.clip(res.x, lb, ub)


SAME_MINIMUM_RTOL = 1e-6
"""Two solutions of one problem whose objectives differ by less than this (relative) are the
same minimum for :func:`lowest_of`: Ipopt's convergence (``tol`` 1e-8 on the scaled NLP error)
leaves the objective uncertain to far less, and distinct minima of these fits differ by 0.1-1 %
(``tests/pins/make_pins.py``: 321.1 against 323.4)."""


def _same_minimum(a: float, b: float) -> bool:
    return abs(a - b) <= SAME_MINIMUM_RTOL * max(1.0, abs(a), abs(b))


def lowest_of(
    problem: EstimationProblem,
    result: EstimationResult,
    others: list,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[EstimationResult | None, list[tuple[str, EstimationResult]], tuple[float, int]]:
    """The starts that lost in :func:`best_of` compared again on ``problem`` (the one the fit
    returns, whose prior widths were estimated from ``result``, its solution): each of
    ``others`` (``(what, result)`` of a problem that differs from ``problem`` only in prior
    widths) solved on ``problem`` from its own point. Returns the lowest of them if its
    objective is below ``result``'s by more than :data:`SAME_MINIMUM_RTOL` (else None), and
    ``(what, result)`` of every start so solved (converged; one per minimum: a start that
    ends where ``result`` or an earlier one did is left out), and the seconds and iterations
    those solves took (a fit's totals count them). The multi-start picked its winner by the
    objective at the starts' widths; the widths estimated afterwards change the objective,
    and a minimum that lost by 0.5 % there can win here (the bundled trial, 168.22 against
    169.00: ``tests/pins/make_pins.py``)."""
    say = progress or (lambda s: None)
    best, record, seconds, iterations = None, [], 0.0, 0
    for what, r0 in others:
        r = solve(
            problem,
            options,
            x0=rescaled_start(r0, problem),
            covariance=False,
            raise_on_failure=False,
            warm=True,
        )
        seconds, iterations = seconds + r.seconds, iterations + r.iterations
        say(
            f"  {what} at the estimated widths: {r.status}, {r.iterations} iterations, "
            f"J = {r.objective:.2f}"
        )
        if not r.success or any(
            _same_minimum(r.objective, o.objective) for o in [result] + [o for _, o in record]
        ):
            continue
        record.append((what, r))
        lowest = result if best is None else best
        if r.objective < lowest.objective and not _same_minimum(r.objective, lowest.objective):
            best = r
    return best, record, (seconds, iterations)


MINIMA_Z = 2.0
"""The plates prefer one of two minima of one problem when their data costs differ by more
than this many standard deviations of that difference's sampling spread (about 97.5 %
one-sided; :func:`undecided_minimum`)."""

MINIMA_SE = 2.0
"""A physical parameter whose value at another minimum (one the plates do not prefer the kept
one to) lies more than this many of its standard errors away (outside its 95 % interval) is
named: its SE does not cover which minimum the fit is in."""


def _frame_costs(problem: EstimationProblem, x: np.ndarray) -> list[np.ndarray]:
    """Per stance, each frame's data cost ``1/2 |r_t|^2`` (its six weighted residuals) at ``x``."""
    r, out, row = problem.data_residuals(x), [], 0
    for b in problem.blocks:
        out.append(0.5 * np.sum(r[row : row + 6 * b.T].reshape(b.T, 6) ** 2, axis=1))
        row += 6 * b.T
    return out


def _sum_sd(series: list[np.ndarray]) -> float:
    """Sampling SD of the sum of ``series`` (one per stance, stances independent), each
    autocorrelated over frames: Newey and West's Bartlett-weighted long-run variance about the
    mean over every frame of every stance (Vuong's: a stance whose differences sit apart from
    the others' is sampling spread too), over the lags the fit's sandwich covariance uses for
    its residuals (the rule of :func:`~gc_ocp.estimation.solve.hac_bandwidth`)."""
    mean = float(np.sum([np.sum(d) for d in series]) / max(1, sum(d.size for d in series)))
    v = 0.0
    for d in series:
        z = d - mean
        lags = hac_bandwidth(z[:, None])
        v += float(z @ z) + sum(
            2.0 * (1.0 - k / (lags + 1.0)) * float(z[k:] @ z[:-k]) for k in range(1, lags + 1)
        )
    return math.sqrt(max(v, 0.0))


def _param_distances(
    problem: EstimationProblem, kept: EstimationResult, a: np.ndarray, b: np.ndarray
) -> list[tuple[float, object, int]]:
    """``(|a - b| / SE, spec, i)`` of every physical parameter's entry ``i`` of ``problem``
    (decision vectors ``a``, ``b``) whose SE in ``kept``'s covariance is positive."""
    se = np.sqrt(np.clip(np.diag(kept.covariance), 0.0, None))
    return [
        (abs(a[s.start + i] - b[s.start + i]) / se[s.start + i], s, i)
        for s in problem.variables.specs
        if s.kind == "param"
        for i in range(s.size)
        if se[s.start + i] > 0
    ]


def physical_distance(
    problem: EstimationProblem, kept: EstimationResult, a: np.ndarray, b: np.ndarray
) -> float:
    """The largest difference of ``a`` and ``b`` (decision vectors of ``problem``) over its
    physical parameters, in units of ``kept``'s standard errors (0 without a covariance)."""
    if kept.covariance is None:
        return 0.0
    return max((z for z, _, _ in _param_distances(problem, kept, a, b)), default=0.0)


def undecided_minimum(
    problem: EstimationProblem, kept: EstimationResult, other: EstimationResult, what: str
) -> dict | None:
    """A ``minimum_undecided`` flag when ``other``, another minimum of ``problem``, fits the
    plates at least as well as ``kept`` and lies far from it: its data cost is not above
    ``kept``'s by :data:`MINIMA_Z` standard deviations of the difference or more (a Vuong-type
    comparison of two fits of one data set, the per-frame cost differences' sum with its
    autocorrelation-robust spread, :func:`_sum_sd`; below by as much, the plates prefer it and
    the priors decide), and a physical parameter lies more than :data:`MINIMA_SE` of its
    standard errors (``kept``'s covariance) away, among those the fit reports with an SE (not
    at a bound, not a unit's stiffness flagged ``unit_not_identified``). Those SEs describe the
    curvature of one minimum, not the choice between two; the fit keeps the lower objective
    and says so. None otherwise (or without a covariance)."""
    if kept.covariance is None:
        return None
    pairs = zip(_frame_costs(problem, other.x), _frame_costs(problem, kept.x), strict=True)
    diff = [a - b for a, b in pairs]
    d_data = float(sum(np.sum(d) for d in diff))
    sd = _sum_sd(diff)
    if not (sd > 0.0) or d_data >= MINIMA_Z * sd:  # the plates prefer the kept minimum
        return None
    far = []
    for z, s, i in _param_distances(problem, kept, other.x, kept.x):
        name = variable_key(*s.key)
        # a value the fit reports without an SE (at a bound, a unit not identified) is flagged
        # as such already: no SE of it to warn about
        if z > MINIMA_SE and not without_se(kept.flags, name):
            name += f"[{i}]" if s.size > 1 else ""
            a, b = (s.reading(s.physical(v[s.slice])[i]) for v in (kept.x, other.x))
            far.append((z, name, a, b))
    if not far:
        return None
    far.sort(reverse=True)
    listed = ", ".join(f"{n} {z:.1f} ({a} kept, {b} other)" for z, n, a, b in far)
    d_prior = float(other.prior_cost - kept.prior_cost)
    better = d_data <= -MINIMA_Z * sd
    return flag(
        "minimum_undecided",
        ", ".join(n for _, n, _, _ in far),
        f"another minimum of the objective, reached by {what}, fits the plates "
        + ("better" if better else "as well")
        + f": its data cost differs by {d_data:+.2f} +- {sd:.2f} "
        + (f"(beyond {MINIMA_Z:g} SD)" if better else f"(within {MINIMA_Z:g} SD)")
        + f", its prior's by {d_prior:+.2f}, and it lies this many standard errors away: "
        f"{listed}. Those SEs do not cover which minimum the fit is in; the fit keeps the "
        "lower objective" + (", which the priors decide" if better else ""),
    )


def frozen_model(model: tuple, result: EstimationResult) -> tuple:
    """The model with every component frozen at ``result``'s blocks (held-out evaluation): the
    contact law and sole corrections fixed, the belt speed fixed for the fitted trials, the
    pose correction (scope ``"stance"``) left free."""
    return tuple(c.frozen(result.blocks[c.name]) if c.name in result.blocks else c for c in model)


__all__ = [
    "CONTINUATION",
    "STRATEGIES",
    "TYPICAL_DEPTH",
    "best_of",
    "lowest_of",
    "physical_distance",
    "trust_region_point",
    "undecided_minimum",
    "estimate",
    "frozen_model",
    "neutral_points",
    "lls_k0",
    "rescaled_start",
    "with_lls_start",
]
