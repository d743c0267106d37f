"""The Python API's usual slips end in one clear InputError naming the fix (a first-time
user's session, 2026-11-30: each of these raised a TypeError, AttributeError or IndexError
from deep inside), and a notebook shows a trial and its kinematics in one line."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import gc_ocp
from gc_ocp.errors import InputError


@pytest.fixture(scope="module")
def pair():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trial = gc_ocp.load_trial()
        return trial, gc_ocp.compute_kinematics(trial)


@pytest.mark.parametrize(
    "call, needle",
    [
        (lambda t, k: gc_ocp.load_trial(["a.c3d", "b.c3d"]), "one trial's file, but got list"),
        (lambda t, k: gc_ocp.compute_kinematics([t]), "one loaded trial, but got list"),
        (lambda t, k: gc_ocp.compute_kinematics("walk.c3d"), "one loaded trial, but got str"),
        (lambda t, k: gc_ocp.fit([(t, k)], holdout=0), "holdout=0: give a stance"),
        (lambda t, k: gc_ocp.fit([(t, k)], model=["friction"]), "model_from_names"),
        (lambda t, k: gc_ocp.fit([(t, k)], model="full"), "give a tuple of components"),
        (lambda t, k: gc_ocp.plot_fit(3), "expected a fit"),
        (lambda t, k: gc_ocp.plot_fit("no_such_fit.json"), "does not exist"),
        # a review of 2026-12-02: each was an AttributeError or TypeError from inside (the
        # path given as a file was told "got an empty list")
        (lambda t, k: gc_ocp.describe_trial("walk.c3d"), "takes one loaded trial, but got str"),
        (lambda t, k: gc_ocp.load_static(t, "static.c3d"), "static trial's file first"),
        (lambda t, k: gc_ocp.load_static("static.c3d", "walk.c3d"), "walking trial second"),
        (lambda t, k: gc_ocp.compute_kinematics(t, model="x"), "BodyModel.from_subject"),
        (lambda t, k: gc_ocp.stance_data(t, k, "right@0.407"), "one of the trial's stances"),
        (lambda t, k: gc_ocp.trial_stances(t, t), "kinematics second, but got Trial"),
        (lambda t, k: gc_ocp.diagnose_stances([(t, k)]), "item 0 is tuple"),
        (lambda t, k: gc_ocp.build_estimation([(t, k)], gc_ocp.full_model()), "trial_stances"),
        (lambda t, k: gc_ocp.build_estimation(gc_ocp.trial_stances(t, k), "full"), "tuple of"),
        (lambda t, k: gc_ocp.solve(gc_ocp.trial_stances(t, k)), "build_estimation"),
        (lambda t, k: gc_ocp.fit([(t, k)], weights={"force_sigma": 0.01}), "gc_ocp.Weights"),
        (lambda t, k: gc_ocp.fit([(t, k)], options={"max_iter": 50}), r"IpoptOptions\(\*\*"),
        (lambda t, k: gc_ocp.diagnose([(t, k)], options={"max_iter": 50}), "IpoptOptions"),
        (lambda t, k: gc_ocp.fit([(t, k)], margin="30ms"), "margin must be a number in s"),
        (lambda t, k: gc_ocp.fit("walk.c3d"), "got str 'walk.c3d'.*load_trial"),
        # a new user's walk of 2026-12-03: fit(trial, kin) was told its model= was no model
        (lambda t, k: gc_ocp.fit(t, k), r"a Trial on its own.*gc_ocp.fit\(\[\(trial, kin\)\]\)"),
        (lambda t, k: gc_ocp.diagnose(t, k), r"a Trial on its own.*list of \(trial, kin"),
        (lambda t, k: gc_ocp.fit([(t, k)], start="no_such_fit.json"), "does not exist"),
        (lambda t, k: gc_ocp.diagnose([(t, k)], candidats=["damping"]), "'candidats'.*candidates"),
        # the README's CLI names tried in Python (a new user's walk, 2026-12-03)
        (
            lambda t, k: gc_ocp.diagnose([(t, k)], null_draws=8),
            "--null-draws: here mismatch_draws=",
        ),
        (lambda t, k: gc_ocp.diagnose([(t, k)], effects=["damping"]), "here candidates="),
        (lambda t, k: gc_ocp.ContactLaw(mu=0.8), r"mu=Param\('fixed', 0.8\)"),
        # found writing Param's docstring example (2026-12-03): reversed bounds were CasADi's
        # RuntimeError "Ill-posed problem detected" at the first solve
        (lambda t, k: gc_ocp.Param("shared", 0.3, 10, 0), r"lower <= upper.*lower=10, upper=0"),
        (lambda t, k: gc_ocp.Param("shared", 0.3, "0", 10), r"must be numbers.*lower='0'"),
        # a scope the package does not know was a ModelError only (not caught as bad input)
        (lambda t, k: gc_ocp.Param("global", 0.8), r'scope must be one of.*"global"'),
        # a per-foot value without the other foot was a bare KeyError('right') at the build
        (
            lambda t, k: gc_ocp.build_estimation(
                gc_ocp.trial_stances(t, k),
                (gc_ocp.ContactLaw(mu=gc_ocp.Param("fixed", {"left": 0.8})),),
            ),
            r"no side 'right' \(it gives 'left'\).*for each foot",
        ),
        # a percentage where a fraction of body weight is taken: plates weighted 100x too
        # lightly against the priors, silently
        (lambda t, k: gc_ocp.Weights(force_sigma=2), "fraction of body weight"),
        (lambda t, k: gc_ocp.Weights(torque_length=250), "length in m"),
        # a review of 2026-12-04: Ipopt refused each at the first solve with CasADi's
        # RuntimeError "Invalid options were detected by Ipopt" (its option text on stdout), a
        # bad hessian was a ModelError from inside the solve, a misspelt field a TypeError, and
        # a fractional max_iter was cut to a whole one silently
        (lambda t, k: gc_ocp.IpoptOptions(max_iter=-5), r"max_iter=-5\).*whole number >= 0"),
        (lambda t, k: gc_ocp.IpoptOptions(max_iter=2.5), r"max_iter=2.5\).*whole number"),
        (lambda t, k: gc_ocp.IpoptOptions(tol=0), r"tol=0\).*number > 0"),
        (lambda t, k: gc_ocp.IpoptOptions(tol="1e-8"), r"tol='1e-8'\).*number > 0"),
        (lambda t, k: gc_ocp.IpoptOptions(acceptable_iter=-1), r"acceptable_iter=-1\)"),
        (lambda t, k: gc_ocp.IpoptOptions(print_level=20), r"print_level=20\).*0 to 12"),
        (lambda t, k: gc_ocp.IpoptOptions(warm_mu_init=0.0), r"warm_mu_init=0.0\).*or None"),
        (lambda t, k: gc_ocp.IpoptOptions(warm_bound_push=0.9), r"warm_bound_push=0.9\).*0.5"),
        (
            lambda t, k: gc_ocp.IpoptOptions(hessian="exact-ish"),
            r"hessian='exact-ish'\).*'exact', 'gauss-newton'",
        ),
        (
            lambda t, k: gc_ocp.IpoptOptions(linear_solver="nosuch"),
            r"linear_solver='nosuch'\).*ma27.*available here: mumps",
        ),
        (lambda t, k: gc_ocp.IpoptOptions(max_iters=50), "no field 'max_iters'.*'max_iter'"),
        (lambda t, k: gc_ocp.Weights(force_sigms=0.01), "no field 'force_sigms'.*'force_sigma'"),
    ],
)
def test_a_slip_is_one_clear_error(pair, call, needle):
    with pytest.raises(InputError, match=needle):
        call(*pair)


def test_a_linear_solver_ipopt_cannot_load_is_named_at_construction():
    """HSL's MA27 where HSL is not installed (Ipopt loads its library, ``libhsl``, only when a
    solve starts) was a SolveError "did not converge: Invalid_Option after -1 iterations" at the
    first solve; now it is refused when the options are made, with the solvers this Ipopt has.
    Where HSL is installed the option is valid and the test does not apply."""
    import ctypes

    try:
        ctypes.CDLL("libhsl.so")
        pytest.skip("HSL is installed: ma27 is a valid linear solver here")
    except OSError:
        pass
    with pytest.raises(InputError, match=r"linear_solver='ma27'\).*available here: mumps"):
        gc_ocp.IpoptOptions(linear_solver="ma27")
    # the default and a spelt-out built-in one are taken
    assert gc_ocp.IpoptOptions(linear_solver="mumps") == gc_ocp.IpoptOptions()


def test_figures_take_the_fit_itself_and_a_side_by_name(pair, tmp_path):
    """``plot_fit(report)`` (what fit returns), its result and its fit.json give one figure;
    the exported law takes ``sides="left"`` as one side (it read "l", "e", "f", "t")."""
    import json

    from gc_ocp.export import casadi_function

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = gc_ocp.fit([pair])
    path = tmp_path / "fit.json"
    path.write_text(json.dumps(report.to_json()))
    lines = [len(gc_ocp.plot_fit(x).axes[0].lines) for x in (report, report.result, path)]
    assert lines[0] > 0 and len(set(lines)) == 1
    # the damping printed with its unit, the pure numbers without (a reader could not tell)
    summary = report.summary()
    assert "shared c [s/m] = " in summary and "shared n = " in summary
    assert "shared mu = " in summary
    # drawn in % BW of the stance's subject, as the fit's RMS is printed (it was in N)
    sup, first = gc_ocp.plot_fit(report).axes[2], report.result.stance_fits[0]  # row 2: superior
    assert sup.get_ylabel() == "superior force\n[% BW]"
    np.testing.assert_allclose(
        sup.lines[0].get_ydata(), 100 * np.asarray(first["measured"])[:, 2] / first["body_weight"]
    )
    # a fit's fit.json as the start of another fit, as plot_fit takes it (was an
    # AttributeError: start took the result only)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = gc_ocp.fit([pair], start=path, pose_scale=False, bias_correction=0)
    assert again.result.success
    # a fit.json cut short of its stance fits: refused by name (it was an IndexError)
    cut = dict(report.to_json(), stance_fits=[])
    from gc_ocp.estimation.plots import plot_sole_fit

    for draw in (gc_ocp.plot_fit, plot_sole_fit):
        with pytest.raises(InputError, match="no stance fits"):
            draw(cut)
    assert casadi_function(report, sides="left").name_out() == ["left_wrench", "left_unit_forces"]


def test_a_trial_and_its_kinematics_print_in_one_line(pair):
    trial, kin = pair
    for text in (repr(trial), repr(kin)):
        assert "\n" not in text and len(text) < 300
    assert "3 stances" in repr(trial) and "63.6 kg" in repr(trial)
    assert "27 coordinates" in repr(kin)


def test_a_trial_s_printout_says_which_mass_and_height_the_package_estimated(pair):
    """A mass estimated from the plates (no mass in the file: the shared data's BTS
    Walking1.c3d) or a height from the markers is marked where the trial is printed, not only
    in the warning that went by at load; a recorded one is printed as it is."""
    import dataclasses

    from gc_ocp.trial import ESTIMATED

    trial, _ = pair
    assert "mass 63.6 kg, height 1.58 m)" in repr(trial)  # the file's: no mark
    guessed = dataclasses.replace(
        trial,
        mass_source=f"{ESTIMATED} 63.6 kg from the force data (walking: ...)",
        height_source=f"{ESTIMATED} from the markers",
    )
    text = repr(guessed)
    assert "mass 63.6 kg (estimated from the plates)" in text
    assert "height 1.58 m (estimated from the markers)" in text
    pooled = dataclasses.replace(
        trial, mass_source=f"{ESTIMATED} 63.6 kg: the mean of the subject's trials' estimates"
    )
    assert "mass 63.6 kg (estimated)" in repr(pooled)


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"mass": "70kg"}, ["mass must be a number in kg", "'70kg'"]),
        ({"mass": [70]}, ["mass must be a number in kg"]),
        ({"height": True}, ["height must be a number in m"]),
        ({"belt_speed": "fast"}, ["belt_speed must be a number in m/s"]),
    ],
)
def test_a_value_that_is_not_a_number_is_named(kw, words):
    """``load_trial(mass="70kg")`` and the like: an InputError naming the argument and its unit
    (they were a ValueError or TypeError from inside). A numeric string stays accepted, as on
    the command line."""
    import gc_ocp
    from gc_ocp.errors import InputError

    with pytest.raises(InputError) as e:
        gc_ocp.load_trial(**kw)
    for w in words:
        assert w in str(e.value)
    assert gc_ocp.load_trial(mass="70").mass == 70.0


def test_kinematics_arguments_of_the_wrong_kind_are_named():
    """A cutoff as text, a static trial given as a path, a walking trial given as the static
    one (the CLI refused it; the API fitted it)."""
    import gc_ocp
    from gc_ocp.errors import InputError

    t = gc_ocp.load_trial()
    with pytest.raises(InputError, match="cutoff_hz must be a number in Hz"):
        gc_ocp.compute_kinematics(t, cutoff_hz="six")
    with pytest.raises(InputError, match="gc_ocp.load_static"):
        gc_ocp.compute_kinematics(t, static="static.c3d")
    with pytest.raises(InputError, match="is not static"):
        gc_ocp.compute_kinematics(t, static=t)


def test_effect_names_and_diagnosis_settings_are_checked(bundled_stances):
    """An unknown effect or base is an InputError (a notebook's except InputError missed the
    ModelError it was), one string is one name (it was split into letters), and workers or
    mismatch draws below their range are refused (they ran serially, or with no draws)."""
    from gc_ocp.diagnosis import diagnose_stances
    from gc_ocp.diagnosis.diagnose import candidate_names, resolve_base
    from gc_ocp.errors import InputError
    from gc_ocp.estimation.components import base_model, model_from_names

    with pytest.raises(InputError, match="Unknown effect"):
        candidate_names(base_model(), ["dampnig"])
    assert candidate_names(base_model(), "damping") == ["damping"]
    with pytest.raises(InputError, match="Unknown base"):
        resolve_base("reg")
    with pytest.raises(InputError, match="Unknown component"):
        model_from_names(["frictoin"])
    assert model_from_names("damping") == model_from_names(["damping"])
    data = list(bundled_stances)
    for kw in ({"workers": 0}, {"workers": -1}, {"mismatch_draws": -3}):
        with pytest.raises(InputError, match="must be"):
            diagnose_stances(data, candidates=["damping"], **kw)


def test_model_from_names_refuses_a_base_that_is_not_components():
    """A base named as diagnose() names it ("registered") was read letter by letter into the
    model (('r', 'e', 'g', ..., Damping(...))), and a preset not called raised a TypeError; each
    is an InputError saying what to give."""
    from gc_ocp.errors import InputError
    from gc_ocp.estimation.components import base_model, full_model, model_from_names

    for base in ("registered", full_model, (base_model(), "damping")):
        with pytest.raises(InputError, match="tuple of components"):
            model_from_names(["damping"], base=base)
    assert model_from_names(["damping"], base=list(base_model())) == model_from_names(
        ["damping"], base=base_model()
    )


def test_a_static_trial_of_another_subject_is_refused():
    """The Rajagopal static trial scaled 1.3 times (another, larger subject): its foot markers
    are 30 % off the walking trial's distances, refused (it was used: height 2.34 m, the
    exponent 2.5 against 1.25). The trial's own static trial passes."""
    import dataclasses
    from pathlib import Path

    from gc_ocp.kinematics.pipeline import check_static_feet
    from gc_ocp.model.markerset import detect_markerset

    data = Path(gc_ocp.__file__).parents[2] / "shared" / "data" / "opensim_rajagopal_overground"
    if not data.is_dir():
        pytest.skip("the shared data are not beside the repository")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = gc_ocp.load_trial(data / "motion_capture_walk.trc", data / "grf_walk.mot", mass=85.07)
        static = gc_ocp.load_static(data / "static_walk_1.trc", t)
    ms = detect_markerset(t.marker_names, t.markers, t.source)
    check_static_feet(static, t, ms)
    larger = dataclasses.replace(static, markers=1.3 * static.markers)
    with pytest.raises(InputError, match="of another subject") as e:
        check_static_feet(larger, t, ms)
    assert "30%" in str(e.value) or "31%" in str(e.value)
