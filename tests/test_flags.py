"""Plausibility flags: each check fires where it should and stays quiet where it should not."""

from __future__ import annotations

import numpy as np

from gc_ocp.estimation import BeltSpeed, ContactLaw
from gc_ocp.estimation.flags import fit_flags, variable_flags
from gc_ocp.estimation.variables import Variables


def _specs():
    v = Variables()
    v.parameter(("contact", "n"), 1.5, 1.0, 3.0)
    v.parameter(("contact", "k", "left", "PL"), 1e5, 1e2, 1e9, log=True)
    v.prior_variable(("sole", "left", "PL"), 3, 0.005, 0.025)
    v.finalize()
    return v.specs


def test_parameter_at_a_bound_and_correction_beyond_three_sigma():
    specs = _specs()
    x = np.array([1.0, np.log(1e5), 0.5, -3.5, 1.0])  # n at its lower bound; a 3.5-sigma offset
    codes = {(f["code"], f["what"]) for f in variable_flags(specs, x)}
    assert codes == {("at_bound", "contact/n"), ("prior_exceeded", "sole/left/PL")}
    x_ok = np.array([1.4, np.log(1e5), 0.5, -2.9, 1.0])
    assert variable_flags(specs, x_ok) == []
    x_kmax = np.array([1.4, np.log(1e9), 0.0, 0.0, 0.0])  # log variable at its upper bound
    assert [f["what"] for f in variable_flags(specs, x_kmax)] == ["contact/k/left/PL"]


def test_a_correction_on_its_bound_inside_three_sigma_is_flagged():
    """An estimated sole width of 10 mm puts the 25 mm bound at 2.5 sigma: a correction stopped
    there is below the prior_exceeded threshold, yet its SE is not meaningful."""
    v = Variables()
    v.prior_variable(("sole", "right", "TT"), 3, 0.010, 0.025)
    v.finalize()
    flags = variable_flags(v.specs, np.array([-2.5, 0.3, 0.0]))
    assert [(f["code"], f["what"]) for f in flags] == [("at_bound", "sole/right/TT")]
    assert "2.5 sigma" in flags[0]["message"]
    assert variable_flags(v.specs, np.array([-2.4, 0.3, 0.0])) == []


def test_unit_not_identified_and_reported_so():
    from types import SimpleNamespace

    block = {
        "left": {
            "PL": {"k": 1e5, "k_se": 1e4, "f_ref": 300.0, "f_ref_se": 20.0},
            "AM": {"k": 8e8, "k_se": 8e8, "f_ref": 2.3e5, "f_ref_se": 1.7e5},  # 360 BW at 5 mm
            "PM": {"k": 1e5, "k_se": 2e5, "f_ref": 29.0, "f_ref_se": 53.0},  # SE above its value
        },
        "shared": {"n": 1.5, "n_se": 0.1},
    }
    stances = [SimpleNamespace(side="left", body_weight=624.0)]
    flags = ContactLaw().flags(block, stances)
    assert sorted(f["what"] for f in flags) == ["left/AM", "left/PM"]
    message = {f["what"]: f["message"] for f in flags}
    assert message["left/PM"].endswith(
        "force at the reference depth 29 N (its SE, 53 N, exceeds it)"
    )
    assert message["left/AM"].endswith("force at the reference depth 2.3e+05 N (369 BW at 5 mm)")
    # just over the 2 BW limit: not rounded down to "2 BW", which would read as within it
    block["left"]["AM"].update(f_ref=2.2 * 624.0, f_ref_se=100.0)
    [am] = ContactLaw().flags({"left": {"AM": block["left"]["AM"]}}, stances)
    assert am["message"].endswith("(2.2 BW at 5 mm)")
    assert block["left"]["PL"]["identified"] and not block["left"]["AM"]["identified"]
    from gc_ocp.estimation.result import _shown

    assert _shown(block["left"], "AM", "k", ".3g") == "AM not identified"


def test_belt_speed_not_informed_and_poor_fit():
    belt = BeltSpeed()
    informed = {"t1": {"value": 1.18, "se": 0.003, "nominal": 1.1, "correction": 0.08}}
    prior_only = {"t2": {"value": 1.1, "se": 0.0999, "nominal": 1.1, "correction": 0.0}}
    assert belt.flags(informed, []) == []
    assert [f["code"] for f in belt.flags(prior_only, [])] == ["belt_not_informed"]
    rms = {"left": {"superior_force_pct_bw": 61.0}, "right": {"superior_force_pct_bw": 1.8}}
    assert [f["what"] for f in fit_flags(rms, {"left": 600.0, "right": 9.0})] == ["left", "left"]
    # an RMS that is not a number is no good fit (nan > 10 is False: it passed unflagged); a
    # COP RMS is NaN where no frame carries 10 % BW, which says nothing of the fit
    rms = {"left": {"superior_force_pct_bw": float("nan")}, "right": {"superior_force_pct_bw": 1.8}}
    [bad] = fit_flags(rms, {"left": float("nan"), "right": 9.0})
    assert bad["what"] == "left" and "not a number" in bad["message"]


def test_a_law_parameter_a_component_gives_is_at_its_bound_as_the_law_s():
    """Damping gives the law its c and the exponent its n: their variables at a bound
    (``damping/c``, ``stiffness_exponent/n/left``) are the law's parameter at its bound, which the
    law's table showed with its SE (it looked for ``contact/c`` only)."""
    from gc_ocp.estimation.flags import law_at_bound

    assert law_at_bound(frozenset({"damping/c"}), "c")
    assert law_at_bound(frozenset({"damping/c"}), "c", "left")  # a shared c is each foot's
    assert law_at_bound(frozenset({"stiffness_exponent/n/left"}), "n", "left")
    assert not law_at_bound(frozenset({"stiffness_exponent/n/left"}), "n", "right")
    assert not law_at_bound(frozenset({"stiffness_exponent/n/left"}), "n")
    assert law_at_bound(frozenset({"contact/mu"}), "mu") and not law_at_bound(frozenset(), "mu")
    assert not law_at_bound(frozenset({"friction/viscous", "time_offset/walk"}), "c")


def test_a_trial_named_like_a_law_parameter_is_not_the_law_s_parameter():
    """A trial ``c.c3d`` (or ``k``, ``n``, ``mu``) keys its belt or clock offset ``belt/c``,
    ``time_offset/k``: such a block at its bound is not the law's ``c`` or every unit's ``k``
    (law_at_bound matched a key by its end and showed those as not estimates)."""
    from gc_ocp.estimation.flags import k_at_bound, law_at_bound

    for p in ("c", "n", "mu", "k"):
        bound = frozenset({f"belt/{p}", f"time_offset/{p}", f"ground_offset/{p}"})
        assert not law_at_bound(bound, p) and not law_at_bound(bound, p, "left"), p
    assert not k_at_bound(frozenset({"belt/k"}), "left", "PM")
    assert not law_at_bound(frozenset({"damping/n"}), "n")  # damping gives c only
    assert not law_at_bound(frozenset({"stiffness_exponent/c"}), "c")
    assert law_at_bound(frozenset({"contact/k/left"}), "k", "left")
    assert k_at_bound(frozenset({"contact/k"}), "right", "PL")


def _bare_result(blocks: dict, flags: list):
    """An :class:`EstimationResult` holding only ``blocks`` and ``flags`` (no stance, no side)."""
    from gc_ocp.estimation.result import EstimationResult

    return EstimationResult(
        x=np.zeros(1),
        status="Solve_Succeeded",
        success=True,
        iterations=1,
        seconds=0.0,
        objective=0.0,
        data_cost=0.0,
        prior_cost=0.0,
        n_data=0,
        n_free=1,
        n_param=0,
        blocks=blocks,
        components={},
        rms={},
        cop_rms_mm={},
        flags=flags,
    )


def test_the_summary_shows_a_belt_speed_at_its_bound_without_its_se():
    """The summary printed a belt speed flagged ``at_bound`` as "1.600 ± 0.000 m/s" while the
    fit's page and the law's parameters say "at its bound" in place of the SE."""
    from gc_ocp.values import BOUND_TEXT

    belt = {"walk": {"value": 1.6, "se": 1e-5, "nominal": 1.1, "correction": 0.5}}
    at = {"code": "at_bound", "what": "belt/walk", "message": "belt/walk: on its bound"}
    line = next(s for s in _bare_result({"belt": belt}, [at]).summary().splitlines() if "belt" in s)
    assert line.startswith(f"belt speed (walk): 1.600 m/s {BOUND_TEXT}") and "±" not in line
    free = _bare_result({"belt": belt}, []).summary()
    assert "belt speed (walk): 1.600 ± 0.000 m/s (from 1.100 m/s" in free


def test_a_bound_flag_quotes_the_value_as_a_person_reads_it():
    """The stiffness exponent stores ``n - 1`` and the toe onset radians: a flag quoted the
    stored numbers ("= 0.35 ... bound 0"), which a reader takes for n = 0.35. It quotes n and
    degrees, and a fit.json written before the reading was kept reads back as stored."""
    from gc_ocp.estimation.components import StiffnessExponent, ToeJoint
    from gc_ocp.estimation.variables import VariableSpec

    v = Variables()
    StiffnessExponent().declare(v, [])
    ToeJoint(drive="pitch").declare(v, [])
    v.finalize()
    lo = np.array([s.lb[0] for s in v.specs])  # every parameter at its lower bound
    message = {f["what"]: f["message"] for f in variable_flags(v.specs, lo)}
    n_spec = v.spec(("stiffness_exponent", "n"))
    assert message["stiffness_exponent/n"].startswith(
        f"stiffness_exponent/n = {1.0 + n_spec.lb[0]:.4g} is at its lower bound "
        f"{1.0 + n_spec.lb[0]:.4g}:"
    )
    onset = next(s for s in v.specs if "onset" in "/".join(map(str, s.key)))
    deg = np.rad2deg(onset.lb[0])
    assert (
        f"= {deg:.4g} deg is at its lower bound {deg:.4g} deg"
        in message["/".join(map(str, onset.key))]
    )
    again = VariableSpec.from_json(n_spec.to_json())
    assert again.shown == n_spec.shown and again.reading(0.35) == "1.35"
    old = {k: x for k, x in n_spec.to_json().items() if k != "shown"}
    assert VariableSpec.from_json(old).reading(0.35) == "0.35"


def test_a_parameter_another_minimum_lies_beyond_says_so_in_the_tables():
    """The variables a ``minimum_undecided`` flag names (its ``what``) are read back from the
    flags, fit.json's included; the shared-parameter tables add the note after the SE, and a
    parameter at its bound keeps the bound's text alone (its SE is no estimate to qualify)."""
    from gc_ocp.estimation.flags import flag, undecided_names
    from gc_ocp.html.fit_tables import shared_pm
    from gc_ocp.values import BOUND_TEXT, MINIMUM_TEXT

    flags = [
        flag("at_bound", "contact/mu", "mu at its bound"),
        flag("minimum_undecided", "contact/k/left/AM, contact/n", "another minimum ..."),
    ]
    names = undecided_names(flags)
    assert names == {"contact/k/left/AM", "contact/n"}
    shared = {"n": 1.16, "n_se": 0.079, "c": 2.0, "c_se": 0.3, "mu": 0.3, "mu_se": 0.01}
    assert shared_pm(shared, "n", frozenset(), names).endswith(MINIMUM_TEXT)
    assert MINIMUM_TEXT not in shared_pm(shared, "c", frozenset(), names)
    at_bound = frozenset({"contact/mu", "contact/n"})
    assert shared_pm(shared, "n", at_bound, names).endswith(BOUND_TEXT)
