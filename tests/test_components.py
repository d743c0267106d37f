"""The component contract: every registered component (and a throw-away one added in one file
plus one registration line) goes through the same checks.

* exact gradient and Hessian of the objective against central finite differences;
* decode -> frozen round trip: the model frozen at a result's blocks predicts the same wrench;
* neutral value = no effect, where the component has one (its variables at zero);
* a changed component signature gives another per-frame function (the cache key).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from ground_shift_component import GroundShift

from gc_ocp.estimation import (
    REGISTRY,
    ContactLaw,
    Param,
    PoseCorrection,
    SoleCorrection,
    Weights,
    build_estimation,
    frozen_model,
    register,
    result_at,
    solve,
)
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import default_truth, synthetic_stance

register("ground_shift", GroundShift)  # the one registration line of the throw-away component

FD_STEP = 1e-6
FD_RTOL = 1e-5
"""Central differences with step h err by ~h^2 |f'''| + eps |f| / h: with h = 1e-6 on O(1)
scaled variables and |J| ~ 1e3, about 1e-7 of the largest gradient entry; 1e-5 leaves room."""


def _stances():
    truth = default_truth()
    rng = np.random.default_rng(0)
    out = []
    for side, t0 in (("left", 0.0), ("right", 0.55)):
        st = synthetic_stance(side, truth, t0=t0, sink=0.010, rng=rng, force_noise=2.0)
        out.append(dataclasses.replace(st, belt_velocity=np.array([-1.0, 0.0, 0.0])))  # a belt
    return out


def _model(name):
    law = ContactLaw(
        k=Param("unit", 2e5, 1e2, 1e9), n=Param("shared", 1.3, 1, 3), c=Param("shared", 0.5, 0, 10)
    )
    return (law,) if name == "contact" else (law, REGISTRY[name]())


NAMES = sorted(REGISTRY)


@pytest.fixture(scope="module")
def stances():
    return _stances()


@pytest.mark.parametrize("name", NAMES)
def test_derivatives_match_finite_differences(stances, name):
    import casadi as ca

    pb = build_estimation(stances, _model(name))
    rng = np.random.default_rng(1)
    x = pb.x0 + 0.2 * rng.normal(size=pb.x0.size)
    f = ca.Function("f", [pb.x], [pb.objective, pb.gradient, pb.hessian])
    J, g, H = (np.asarray(a) for a in f(x))
    g = g.ravel()
    g_fd = np.empty_like(g)
    for i in range(x.size):
        e = np.zeros(x.size)
        e[i] = FD_STEP
        g_fd[i] = (pb.evaluate(x + e) - pb.evaluate(x - e)) / (2 * FD_STEP)
    assert np.abs(g_fd - g).max() <= FD_RTOL * max(1.0, np.abs(g).max()), name
    v = rng.normal(size=x.size)
    grad = ca.Function("g", [pb.x], [pb.gradient])
    Hv_fd = (np.asarray(grad(x + FD_STEP * v)) - np.asarray(grad(x - FD_STEP * v))).ravel() / (
        2 * FD_STEP
    )
    assert np.abs(Hv_fd - H @ v).max() <= FD_RTOL * max(1.0, np.abs(H @ v).max()), name


@pytest.mark.parametrize("name", NAMES)
def test_decode_frozen_round_trip(stances, name):
    """Freezing every component at the blocks decoded at x and rebuilding gives the same model
    wrench (stance-scope variables carried over by key): decode and frozen are inverses.
    Round-off only (k passes through exp/log): 1e-9 of the largest force."""
    model = _model(name)
    pb = build_estimation(stances, model)
    x = pb.x0 + 0.3 * np.random.default_rng(2).normal(size=pb.x0.size)
    x = np.clip(x, pb.lbx, pb.ubx)
    res = result_at(pb, x)
    assert set(res.blocks) == {c.name for c in model}
    fz = build_estimation(stances, frozen_model(model, res))
    xf = fz.x0.copy()
    for s in fz.variables.specs:
        xf[s.slice] = x[pb.variables.spec(s.key).slice]
    ref = pb.stance_wrenches(x)
    for a, b in zip(fz.stance_wrenches(xf), ref, strict=True):
        assert np.abs(a - b).max() <= 1e-9 * np.abs(ref[0]).max(), name


@pytest.mark.parametrize("name", [n for n in NAMES if REGISTRY[n].neutral_at_zero])
def test_neutral_value_has_no_effect(stances, name):
    base = build_estimation(stances, _model("contact"))
    pb = build_estimation(stances, _model(name))
    x = pb.x0.copy()
    own = REGISTRY[name]().name
    for s in pb.variables.specs:
        if s.key[0] == own:
            x[s.slice] = 0.0
        else:
            x[s.slice] = base.x0[base.variables.spec(s.key).slice]
    for a, b in zip(pb.stance_wrenches(x), base.stance_wrenches(base.x0), strict=True):
        np.testing.assert_array_equal(a, b)


def test_frame_function_cache_follows_the_signature(stances):
    a = build_estimation(stances[:1], (ContactLaw(),)).blocks[0].fm
    b = build_estimation(stances[:1], (ContactLaw(depth_smoothing=1e-3),)).blocks[0].fm
    c = build_estimation(stances[:1], (ContactLaw(k=Param("unit", 1e5, 1, 1e9)),)).blocks[0].fm
    assert a is not b  # the smoothing changes the expression graph
    assert a is c  # a parameter's start value only enters through the slots


def _with_widths(name):
    """``_model(name)`` with a sole and a pose correction, where it has none: every component
    that has prior widths, beside the one named."""
    model = _model(name)
    extra = [
        c
        for c in (SoleCorrection(), PoseCorrection(marker_noise=False))
        if c.name not in {m.name for m in model}
    ]
    return model + tuple(extra)


@pytest.mark.parametrize("name", NAMES)
def test_a_model_with_other_prior_widths_is_the_same_problem_rescaled(stances, name):
    """``width_fields`` (components/base.py) are widths and nothing else: the problem rebuilt with
    every width 1.7 times wider equals the first problem's parametric one at the rescaled
    columns (objective, gradient, Hessian), which is what lets the continuation's stages and the
    widths' rounds share one solver (``EstimationProblem.rescaled``). The two differ by
    round-off only: the maps' columns are multiplied by the ratio of the widths instead of built
    at the new ones (1e-12 relative leaves room for the sums of ~1e3 terms)."""
    import casadi as ca

    model = _with_widths(name)
    wider = tuple(c.with_prior_scale(1.7) for c in model)
    anchor = build_estimation(stances, model, compile=False)  # the same functions, uncompiled
    rescaled = anchor.rescaled(stances, wider)
    rebuilt = build_estimation(stances, wider, compile=False)
    if rescaled is None:  # only where a width is a parameter's prior weight (toe hinge's pitch)
        assert not np.array_equal(anchor.prior_weights, rebuilt.prior_weights), name
        return
    assert not np.all(rescaled.anchor_scale == 1.0)
    assert np.array_equal(rescaled.lbx, rebuilt.lbx) and np.array_equal(rescaled.ubx, rebuilt.ubx)
    x = np.clip(
        rebuilt.x0 + 0.2 * np.random.default_rng(2).normal(size=rebuilt.x0.size),
        rebuilt.lbx,
        rebuilt.ubx,
    )
    par = anchor.parametric()
    ours = ca.Function("f", [par.x, par.column_scale], [par.objective, par.gradient, par.hessian])
    theirs = ca.Function("f", [rebuilt.x], [rebuilt.objective, rebuilt.gradient, rebuilt.hessian])
    for a, b in zip(ours(x, rescaled.anchor_scale), theirs(x), strict=True):
        a, b = np.asarray(a), np.asarray(b)
        assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(b).max()), name
    # at its own widths, the parametric problem is the problem itself, to the bit
    plain = ca.Function("f", [anchor.x], [anchor.objective, anchor.gradient, anchor.hessian])
    for a, b in zip(ours(x, np.ones(x.size)), plain(x), strict=True):
        assert np.array_equal(np.asarray(a), np.asarray(b)), name


def test_a_rescaled_problem_solves_as_the_rebuilt_one(stances):
    """The solver of the anchor, reused at another scale, ends where a solver of the rebuilt
    problem ends (the same Ipopt path up to round-off: 1e-8 relative on the objective and 1e-5
    on the stored variables, Ipopt's tolerance), and anything other than a width change is not
    a rescaling (a pose spline with other knots)."""
    model = _with_widths("contact")
    anchor = build_estimation(stances, model)
    first = solve(anchor)
    wider = tuple(c.with_prior_scale(2.5) for c in model)
    rescaled, rebuilt = anchor.rescaled(stances, wider), build_estimation(stances, wider)
    # the first solution in the wider problem's units (its corrections are stored in units of
    # their widths: first.x as it is lies outside the wider problem's bounds, which solve refuses)
    x0 = rescaled_start(first, rebuilt)
    a = solve(rescaled, x0=x0, warm=True)
    b = solve(rebuilt, x0=x0, warm=True)
    assert a.objective == pytest.approx(b.objective, rel=1e-8)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-5, atol=1e-5)
    other = tuple(
        dataclasses.replace(c, knot_spacing=0.2) if isinstance(c, PoseCorrection) else c
        for c in model
    )
    assert anchor.rescaled(stances, other) is None


def test_throwaway_component_is_fitted():
    """The ground under both feet is 4 mm higher than the plates say: the throw-away
    GroundShift component, unknown to the estimator, recovers it (noiseless data; the exponent,
    damping and friction fixed at their true values, k free per unit)."""
    from gc_ocp.contact.equivalent_wrench import LawParams, model_wrench
    from gc_ocp.contact.laws import Smoothing

    truth = default_truth()
    law = LawParams(
        truth["n"], truth["c"], truth["mu"], smooth=True, smoothing=Smoothing(5e-4, 1e-2, 0.05)
    )
    sts = []
    for side, t0 in (("left", 0.0), ("right", 0.55), ("left", 1.1), ("right", 1.65)):
        st = synthetic_stance(side, truth, t0=t0, sink=0.012)
        f = st.foot
        w = model_wrench(
            f.positions, f.velocities, truth["k"], st.reference_point, law, ground_height=0.004
        )
        sts.append(st.with_measured(w))
    model = (
        ContactLaw(
            k=Param("unit", 2e5, 1e2, 1e9),
            n=Param("fixed", truth["n"]),
            c=Param("fixed", truth["c"]),
            mu=Param("fixed", truth["mu"]),
        ),
        GroundShift(),
    )
    res = solve(build_estimation(sts, model, Weights(force_sigma=1e-3)))
    for side in ("left", "right"):
        # noiseless: the shift is recovered to a small fraction of a millimetre
        assert res.blocks["ground_shift"][side]["mm"] == pytest.approx(4.0, abs=0.1), res.blocks
    assert res.components["ground_shift"] == "GroundShift"


SHOWN_BY_THE_SUMMARY_ITSELF = {"contact", "belt_speed", "sole_geometry", "kinematic_correction"}
"""Blocks laid out per side by ``EstimationResult.summary`` itself (no rows of their own)."""


@pytest.mark.parametrize("name", NAMES)
def test_describe_shows_the_block_in_the_summary_and_after_json(stances, name):
    """Every component's rows (``describe``) are typed, read the decoded block only (the same
    rows from a result read back from JSON) and appear in the summary; every other component
    (an effect's own parameters) has rows."""
    import json

    from gc_ocp.estimation import EstimationResult, SummaryRow

    model = _model(name)
    pb = build_estimation(stances, model)
    x = np.clip(pb.x0 + 0.3 * np.random.default_rng(2).normal(size=pb.x0.size), pb.lbx, pb.ubx)
    res = result_at(pb, x)
    own = model[-1].name
    rows = type(model[-1]).describe(res.blocks[own])
    if name in SHOWN_BY_THE_SUMMARY_ITSELF:
        assert rows == [] and own not in res.block_rows()
        return
    assert rows, name
    for r in rows:
        assert isinstance(r, SummaryRow) and isinstance(r.label, str) and isinstance(r.unit, str)
        assert np.isfinite(r.value) and (np.isnan(r.se) or r.se >= 0), r
    assert res.block_rows()[own] == rows
    # a row's key names one of the component's variables, as the flags name it (so a value at
    # its bound is shown without its SE)
    from gc_ocp.estimation.flags import row_at_bound, variable_key

    declared = {variable_key(*s.key) for s in pb.variables.specs}
    assert all(variable_key(own, *r.key) in declared for r in rows if r.key), (rows, declared)
    text = res.summary()
    assert all(f"{own} {r.text(row_at_bound(res.at_bound, own, r))}" in text for r in rows), text
    back = EstimationResult.from_json(json.loads(json.dumps(res.to_json())))
    assert back.block_rows() == res.block_rows()


def test_describe_reads_the_values_of_the_block():
    """The rows carry the block's numbers in the stated units (damping c in s/m; a ground
    offset's dz in mm and tilts in degrees from the block's SI values)."""
    from gc_ocp.estimation.components import Damping, GroundOffset

    assert Damping.describe({"c": 0.7, "c_se": 0.05}) == [("c", 0.7, 0.05, "s/m", ("c",))]
    block = {
        "s1": {
            "dz": 0.002, "dz_se": 0.001, "tilt_x": 0.01, "tilt_x_se": 0.002, "tilt_y": -0.01,
            "tilt_y_se": 0.004, "dz_mm": 2.0, "tilt_x_deg": np.rad2deg(0.01),
            "tilt_y_deg": np.rad2deg(-0.01),
        }
    }  # fmt: skip
    rows = GroundOffset.describe(block)
    assert [r.label for r in rows] == ["s1 dz", "s1 tilt_x", "s1 tilt_y"]
    # keyed by the stance's block (its three entries are one variable the flags name)
    assert rows[0][1:] == (2.0, 1.0, "mm", ("s1",))
    from gc_ocp.estimation.flags import row_at_bound

    bound = frozenset({"ground_offset/s1"})  # the flag of a correction on its bound
    assert all(row_at_bound(bound, "ground_offset", r) for r in rows)
    assert "at its bound" in rows[1].text(True) and "±" not in rows[1].text(True)
    assert not any(row_at_bound(frozenset({"ground_offset/s2"}), "ground_offset", r) for r in rows)
    assert rows[2].value == pytest.approx(-0.5729578, rel=1e-6)  # -0.01 rad in deg
    assert rows[2].se == pytest.approx(0.2291831, rel=1e-6)  # 0.004 rad in deg


def test_effects_are_the_candidates_in_registry_order():
    """``EFFECTS`` is derived from the registry (``candidate = True``) and keeps the order the
    diagnosis's figures were made with."""
    from gc_ocp.estimation import EFFECTS
    from gc_ocp.estimation.components import candidate_effects

    assert EFFECTS == (
        "damping",
        "stiffness_exponent",
        "sole_geometry",
        "kinematic_correction",
        "contact_density",
        "toe_joint",
        "ground_offset",
        "time_offset",
        "friction",
    )
    assert candidate_effects() == EFFECTS  # ground_shift (registered above) is no candidate
    assert not REGISTRY["contact"].candidate and not REGISTRY["belt_speed"].candidate


def test_components_change_others_through_their_hooks():
    """Damping, stiffness exponent and contact density change the law and the sole through the
    hooks of the changed component (no-ops elsewhere); the results are the former rewrites."""
    from gc_ocp.errors import ModelError
    from gc_ocp.estimation import full_model
    from gc_ocp.estimation.components import (
        ContactDensity,
        Damping,
        PoseCorrection,
        SoleCorrection,
        StiffnessExponent,
    )
    from gc_ocp.estimation.components.contact_density import DenseSoleCorrection

    law, sole, pose, belt = full_model()
    assert law.law_estimates("c") and law.law_estimates("n")
    assert not pose.law_estimates("c") and pose.with_law_fixed("c", 0.0) is pose
    assert law.for_layout(*ContactDensity().design()[::-1]) is law
    with pytest.raises(ModelError, match="Unknown contact-law parameter"):
        law.with_law_fixed("q", 1.0)
    assert Damping().configure(full_model())[0] == dataclasses.replace(law, c=Param("fixed", 0.0))
    assert StiffnessExponent().configure(full_model())[0].n == Param("fixed", 1.0)
    assert Damping.present_in(full_model()) and StiffnessExponent.present_in(full_model())
    W, layout = ContactDensity().design()
    dense_law, dense_sole, *rest = ContactDensity().configure(full_model())
    assert dense_law.k == Param("fixed", 1.0) and rest == [pose, belt]
    assert dense_sole == DenseSoleCorrection(W=tuple(map(tuple, W)), sigma=sole.sigma)
    assert dense_sole.for_layout(layout, W) is dense_sole  # already dense
    assert type(SoleCorrection().for_layout(layout, W)) is DenseSoleCorrection
    assert PoseCorrection().for_layout(layout, W) == PoseCorrection()


@pytest.mark.parametrize(
    "name, field",
    [
        ("kinematic_correction", "sigma_mm"),
        ("kinematic_correction", "sigma_deg"),
        ("ground_offset", "sigma_mm"),
        ("sole_geometry", "sigma"),
    ],
)
def test_a_prior_width_of_zero_is_refused_naming_the_block(stances, name, field):
    """A correction's prior width of 0 made its bounds 0/0 = NaN, which Ipopt met with an
    assertion (``PoseCorrection(sigma_mm=0)``); it is an input error naming the block."""
    from gc_ocp.errors import InputError

    law, comp = _model(name)
    zero = dataclasses.replace(comp, **{field: 0.0})
    with pytest.raises(InputError, match=f"prior width of {comp.name}.* must be a number > 0"):
        build_estimation(stances, (law, zero), compile=False)


def test_a_fit_records_its_law_s_settings_and_the_export_uses_them(stances):
    """A law of other settings (smoothings, their forms, the reference depth) than the defaults:
    the fit records them (``contact_law``), its summary names its reference depth, and the fit
    read back from JSON gives the export that law. Before, ``fit.json`` had no settings and the
    export rebuilt the default law (0.5 mm hyperbola, 0.05 m/s algebraic): a simulator would run
    another contact than the one fitted, silently."""
    import json

    from gc_ocp.estimation import EstimationResult
    from gc_ocp.export.calibrated import CalibratedContact

    own = dict(
        depth_smoothing=1e-3,
        slip_smoothing=0.02,
        reference_depth=0.004,
        depth_form="softplus",
        slip_form="tanh",
    )
    law = dataclasses.replace(_model("contact")[0], **own)
    pb = build_estimation(stances, (law,))
    res = result_at(pb, pb.x0)
    assert res.contact_law == own and res.law.settings() == own
    assert "force at the 4 mm reference depth" in res.summary()
    from gc_ocp.html.fit_tables import contact_tables

    assert contact_tables(res.params, res.at_bound, res.law.reference_depth)["reference_mm"] == "4"
    back = EstimationResult.from_json(json.loads(json.dumps(res.to_json())))
    assert back.contact_law == own
    cal = CalibratedContact.from_fit(back)
    assert cal.law.settings() == own
    # a fit.json written before the settings were recorded: the defaults, as it was fitted with
    old = res.to_json()
    del old["contact_law"]
    assert EstimationResult.from_json(old).law.settings() == ContactLaw().settings()


@pytest.mark.parametrize(
    "law, needle",
    [
        (
            lambda: ContactLaw(c=Param("shared", 20.0, 0.0, 10.0)),
            r"the start of ContactLaw\(c=Param\('shared', 20.0, 0.0, 10.0\)\), 20.0, lies outside "
            r"its bounds \[0.0, 10.0\]: give a start within them, or widen its bounds",
        ),
        (
            lambda: ContactLaw(mu=Param("foot", {"left": 0.5, "right": 2.0}, 0.0, 1.5)),
            r"mu=.* at right, 2.0, lies outside its bounds \[0.0, 1.5\]",
        ),
        (
            lambda: ContactLaw(k=Param("unit", {"left": {"PL": 50.0}}, 1e2, 1e9)),
            r"k=.* at left/PL, 50.0, lies outside its bounds \[100.0, 1000000000.0\]",
        ),
        (lambda: ContactLaw(n=Param("shared", float("nan"), 1.0, 3.0)), r"\), nan, lies outside"),
    ],
)
def test_a_param_started_outside_its_bounds_is_refused_by_name(law, needle):
    """A start outside its bounds was accepted silently: Ipopt moved it inside (its
    bound_push), the prior still centred outside, a fit from a start the user did not get."""
    from gc_ocp.errors import InputError

    with pytest.raises(InputError, match=needle):
        law()
    ContactLaw(c=Param("fixed", 20.0))  # a fixed value is no start: its bounds do not apply


def test_a_component_started_outside_its_bounds_is_refused_by_name():
    """Every parameter a component declares is checked where it is declared: the damping's
    start, c = 20 s/m beside its bounds [0, 10], and the exponent's (stored n - 1, read as n)."""
    from gc_ocp.errors import InputError
    from gc_ocp.estimation.components.damping import Damping
    from gc_ocp.estimation.components.stiffness_exponent import StiffnessExponent
    from gc_ocp.estimation.variables import Variables

    with pytest.raises(
        InputError, match=r"start of damping/c, 20, lies outside its bounds \[0, 10\]"
    ):
        Damping(value=20.0).declare(Variables(), [])
    with pytest.raises(InputError, match=r"stiffness_exponent/n, 4, .*bounds \[1, 3\]"):
        StiffnessExponent(value=4.0).declare(Variables(), [])


def test_a_computed_start_outside_the_bounds_is_clipped_into_them():
    """The LLS start converted to a law started at n = 3 multiplies the linear k by 40 000: a
    unit of 50 kN/m starts at 2e9 N/m^3, beyond k's bound of 1e9 (and one barely loaded, at 1
    N/m, below 1e2). A computed start is clipped into the bounds, as Ipopt would move it, so that
    the start and the log-k prior's centre are the point the solve starts from."""
    law = ContactLaw(n=Param("shared", 3.0, 1.0, 3.0))
    started = law.with_initial_k({"left": {"PL": 5e4 * 0.005**-2, "PM": 1.0, "AL": 3e5}})
    assert started.k.value == {"left": {"PL": 1e9, "PM": 1e2, "AL": 3e5}}
    assert started.k.lower == 1e2 and started.k.upper == 1e9
