"""Today's numbers, pinned (generated before the composable-estimator refactor by
``tests/pins/make_pins.py``; see its docstring). Every later change of the estimator keeps them.

* objective, gradient and Hessian of the full model at a fixed decision vector, on a synthetic
  problem and on the bundled trial's stances (stored inputs, independent of the kinematics), to
  1e-12 relative: the same expression graph evaluated in another order differs by a few ulps of
  the largest term, and sums here have ~1e3 terms of magnitude <= the largest;
* the estimator's per-frame model wrench against the NumPy evaluation of the equivalent wrench
  (:func:`gc_ocp.contact.equivalent_wrench.model_wrench` on unit trajectories from
  :meth:`FootKinematics.with_points`), at the same 1e-12;
* the fitted objective and RMS of the shared trials (``fit_pins.json``), to the solver's tolerance.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pytest

PINS = Path(__file__).resolve().parent / "pins"
RTOL_ROUNDOFF = 1e-12


@pytest.fixture(scope="module")
def pins():
    return np.load(PINS / "estimator_pins.npz", allow_pickle=False)


def _stances(pins, prefix):
    from gc_ocp.foot import FootKinematics
    from gc_ocp.stance import StanceData

    out = []
    for i in range(int(pins[f"{prefix}/n_stances"])):
        p = f"{prefix}/stance{i}/"
        trial, side, label = (str(s) for s in pins[p + "names"])
        gh, bw, h = (float(v) for v in pins[p + "scalars"])
        foot = FootKinematics(
            side,
            pins[p + "time"],
            pins[p + "hindfoot_pose"],
            pins[p + "toes_pose"],
            pins[p + "hindfoot_twist"],
            pins[p + "toes_twist"],
            pins[p + "points_local"],
        )
        out.append(
            StanceData(
                trial=trial,
                side=side,
                label=label,
                foot=foot,
                measured=pins[p + "measured"],
                in_contact=pins[p + "in_contact"],
                reference_point=pins[p + "reference_point"],
                ground_height=gh,
                belt_velocity=pins[p + "belt_velocity"],
                body_weight=bw,
                height=h,
            )
        )
    return out


def _key_str(key) -> str:
    return "/".join(map(str, key))


def _problem(stances):
    """(problem, {key string: slice}) of the full model."""
    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.problem import build_estimation

    pb = build_estimation(stances, full_model())
    return pb, {_key_str(s.key): s.slice for s in pb.variables.specs}


def _permutation(pins, prefix, index, stances) -> np.ndarray:
    """``perm`` such that ``new_vector[perm] == pinned_vector`` (variables matched by key).

    The pins were written when the pose correction's variables were keyed by stance index
    (``pose/0/trans``); they are now keyed by stance label (``pose/<label>/trans``, so that a
    fold can warm-start from a fit on all stances). Only the key's name changed: the pinned key
    is renamed, the numbers are compared unchanged."""
    labels = [st.label for st in stances]
    keys = [_renamed(str(k), labels) for k in pins[f"{prefix}/keys"]]
    assert set(keys) == set(index), "the variables of the full model changed"
    perm = np.empty(sum(int(s) for s in pins[f"{prefix}/sizes"]), dtype=int)
    for k, start, size in zip(keys, pins[f"{prefix}/starts"], pins[f"{prefix}/sizes"], strict=True):
        sl = index[k]
        assert sl.stop - sl.start == size, k
        perm[start : start + size] = np.arange(sl.start, sl.stop)
    return perm


def _renamed(key: str, labels: list[str]) -> str:
    parts = key.split("/")
    if parts[0] == "pose" and len(parts) == 3 and parts[1].isdigit():
        parts[1] = labels[int(parts[1])]
    return "/".join(parts)


@pytest.mark.parametrize("prefix", ["synthetic", "bundled"])
def test_objective_gradient_hessian_are_pinned(pins, prefix):
    stances = _stances(pins, prefix)
    pb, index = _problem(stances)
    perm = _permutation(pins, prefix, index, stances)
    x = np.empty(perm.size)
    x[perm] = pins[f"{prefix}/x"]
    J, g, H = (
        np.asarray(a) for a in ca.Function("f", [pb.x], [pb.objective, pb.gradient, pb.hessian])(x)
    )
    J_pin, g_pin, H_pin = (pins[f"{prefix}/{n}"] for n in ("objective", "gradient", "hessian"))
    assert float(J.ravel()[0]) == pytest.approx(float(J_pin), rel=RTOL_ROUNDOFF)
    g = g.ravel()[perm]
    H = H[np.ix_(perm, perm)]
    assert np.abs(g - g_pin).max() <= RTOL_ROUNDOFF * np.abs(g_pin).max()
    assert np.abs(H - H_pin).max() <= RTOL_ROUNDOFF * np.abs(H_pin).max()


def test_per_frame_model_equals_the_numpy_wrench(pins):
    """Sole offsets on, pose correction zero: the estimator's model wrench of every stance equals
    the NumPy evaluation of the equivalent wrench on the corrected unit trajectories."""
    from gc_ocp.contact.equivalent_wrench import LawParams, model_wrench
    from gc_ocp.contact.laws import Smoothing
    from gc_ocp.foot import UNITS

    stances = _stances(pins, "bundled")
    pb, index = _problem(stances)
    rng = np.random.default_rng(11)
    x = pb.x0.copy()
    for k, sl in index.items():
        if k.startswith("sole/"):
            x[sl] = rng.normal(size=sl.stop - sl.start)  # ~5 mm offsets (stored in sigmas)
        elif k.startswith("contact/k/"):
            x[sl] += 0.3 * rng.normal()
    x[index["contact/n"]] = 1.4
    x[index["contact/c"]] = 0.7
    x[index["contact/mu"]] = 0.6
    wrenches = pb.stance_wrenches(x)
    for st, w in zip(stances, wrenches, strict=True):
        off = np.array([x[index[f"sole/{st.side}/{u}"]] * 0.005 for u in UNITS])
        foot = st.foot.with_points(st.foot.points_local + off)
        k = np.array([np.exp(x[index[f"contact/k/{st.side}/{u}"]][0]) for u in UNITS])
        law = LawParams(n=1.4, c=0.7, mu=0.6, smooth=True, smoothing=Smoothing(5e-4, 1e-2, 0.05))
        ref = model_wrench(
            foot.positions,
            foot.velocities,
            k,
            st.reference_point,
            law,
            st.ground_height,
            st.belt_velocity,
        )
        got = w
        assert np.abs(got - ref).max() <= RTOL_ROUNDOFF * np.abs(ref).max()
