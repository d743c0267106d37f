"""Write the pinned numbers of the estimator (run by hand, only on a deliberate model change).

Generated once at commit bb2d7d0 (before the composable-estimator refactor) with::

    .venv/bin/python tests/pins/make_pins.py

* ``estimator_pins.npz``: for a synthetic problem (4 stances) and for the bundled trial (its
  stance inputs are stored too, so the pin does not depend on the kinematics pipeline), the
  objective, gradient and dense Hessian of the full model at a fixed decision vector, with the
  variable layout (key, start, size) so that a later ordering of the variables can be mapped.
* ``fit_pins.json``: fitted objective and RMS per channel of the three shared trials and the
  bundled trial's held-out fit (the figures ``tests/test_pins.py`` keeps).

``fit_pins.json`` regenerated (``--fits-only``) on deliberate changes: issue 21 (one start path,
see ``docs/architecture.md``); issue 22, plates the lab zeroed below a threshold censored
(``gc_ocp/estimation/measurement.py``; the bundled trial's and Plug-in Gait's plates are zeroed
below about 10 N): bundled 394.50 -> 394.46 (held out 290.21 -> 290.00), Plug-in Gait
599.52 -> 599.31, Rajagopal and Gait2392 unchanged (their MOT zeros rise continuously: no
level to censor); issue 23, the markers' measured noise modelled in the pose correction
where it matters (``gc_ocp/marker_noise.py``): Rajagopal 691.35 -> 672.04 (its
markers measure 0.13 mm of white noise), the others unchanged to round-off (their markers were
low-passed before export); issue 23, the pose correction's smooth width estimated from the
stances by default (``gc_ocp/estimation/pose_scale.py``): bundled 394.46 -> see the json (its
held-out stance too), Plug-in Gait 599.31 -> 275.29, Rajagopal 672.04 -> 333.53, Gait2392
321.38 -> 217.32 (the objective's prior term is in units of the estimated, wider widths);
issue 24, the sole correction's width estimated too by default (``docs/quality.md``): bundled
194.33 -> 171.12 (its held-out stance right@0.407s 150.12 -> 166.40: superior force 1.57 ->
1.70 % BW), Plug-in Gait 275.29 -> 249.70, Rajagopal 333.53 -> 290.90, Gait2392 217.32 ->
189.78; in-sample superior RMS lower on every foot (e.g. Gait2392 right 0.92 -> 0.75 % BW);
2026-11-30, the pose correction a rigid motion at any size (``gc_ocp.geometry.correction_offset``,
the Cayley map; the first-order form stretched the foot at the 13 deg corrections real fits
reach, and the export could not reproduce it): both files, the derivative pins by
``--values-only`` (stored inputs and x kept; synthetic 40784.82 -> 40785.07, bundled
489280.88 -> 489276.34) and ``--fits-only`` (bundled 171.12 -> 178.01, held out 166.40 -> 159.75;
Plug-in Gait 249.70 -> 250.34; Rajagopal 297.48 -> 265.05; Gait2392 189.78 -> 192.97; superior
RMS moved 0.16 % BW at most on any foot (Rajagopal right 1.17 -> 1.01; the bundled feet
+0.09), the held-out stance 1.70 -> 1.71 % BW); 2026-11-30, the sole correction's width
estimated per foot-frame axis and never below its 5 mm prior (``docs/quality.md``, *The
sole's width per axis, and its floor*), ``--fits-only``: bundled 178.01 -> 182.31 (held out
159.75 -> 178.85), Plug-in Gait 250.34 -> 256.16, Rajagopal 265.05 -> 264.96, Gait2392
192.97 -> 192.89 (the objectives' prior terms are in units of the new widths); superior RMS
moved 0.04 % BW at most (the held-out stance 1.71 -> 1.74 % BW); 2026-11-29, warm solves start Ipopt's barrier at 1e-4 (``IpoptOptions.warm_mu_init``): the
others unchanged within the pins' tolerance, Rajagopal 290.90 -> 297.48: its continuation's
last stage reached a lower minimum (J 670.03 against 673.27 at the prior's full width), and from
there the width rounds, which approach their fixed point slowly on this trial (one rotation
width still growing 4-5 % a round), stopped after 6 rounds under their 5 % tolerance where they
had run to the 8-round limit (widths 3.26/3.04/2.61 deg against 3.29/4.04/2.56; superior RMS
left 1.08 -> 1.02, right 1.12 -> 1.17 % BW; ``benchmarks/width_fixed_point_output.md`` measures
how far such stops lie from the fixed point); 2026-12-03, the plates read at the frames
through an anti-alias low-pass (``gc_ocp/antialias.py``; point samples had aliased the
heel-strike transient into the compared band), ``--fits-only``: bundled 182.31 -> 169.00
(superior RMS left 1.15 -> 1.05, right 1.32 -> 1.33 % BW; held out 178.85 -> 143.96, 1.74 ->
1.37 % BW), Plug-in Gait 256.16 -> 268.67 (superior RMS 1.18 / 1.24 -> 1.09 / 1.20 % BW),
Rajagopal 264.96 -> 264.83 and Gait2392 192.89 -> 192.64 (their MOT plates were low-passed
at 19-26 Hz by the lab: little above the frames' Nyquist frequency to remove); same day, the
plate's rate taken as samples over duration (Gait2392's MOT time column is rounded to 0.1 ms:
the median step gave 588 Hz for 600), ``--fits-only``: Gait2392 192.64 -> 177.33, the others
unchanged. Its measured wrench moved 0.003-0.004 % BW RMS, but the four starts' continuations
ended in other minima (best J 321.1 -> 323.4 at full width) and the width rounds from there in
another (superior RMS left 1.21 -> 1.13, right 0.75 -> 0.77 % BW, COP 12.9/12.4 -> 11.4/11.5
mm): this treadmill trial's objective has several minima within 1 % of one another, and which
one a fit ends in is decided by details far below the data's noise. 2026-12-03 (evening), the
multi-start's losing starts compared again at the widths estimated from the winner
(``gc_ocp.estimation.pose_scale.lowest_with_widths``: the minimum kept is the lowest of the
problem the fit returns, not of the prior's widths), ``--fits-only``: bundled 169.00 -> 166.64
(the start from the fit without censoring ends at 168.22 against 169.00 at the winner's widths;
superior RMS left 1.05 -> 1.13, right 1.33 -> 1.33 % BW, COP 5.2/7.9 -> 5.0/8.0 mm; held out
143.96 -> 144.74, superior 1.37 % BW unchanged), the others unchanged (Gait2392's other
minimum ends at 184.13 against 177.33 there). Same evening, a third start, Ipopt after a few
trust-region steps (``gc_ocp.estimation.starts.trust_region_point``: Ipopt's first line-search
steps from the problem's start can cross into a worse basin), ``--fits-only``: Plug-in Gait
268.67 -> 235.73 (superior RMS 1.09/1.20 -> 1.12/1.12 % BW, COP 5.0/10.2 -> 5.4/7.1 mm),
Gait2392 177.33 -> 168.78 (the new start wins at the estimated widths; superior 1.15/0.79 ->
1.14/0.78, COP 11.4/11.5 -> 8.9/11.7), Rajagopal 264.83 -> 267.09 (the new start wins at the
prior's widths, 671 against 696, and its width rounds end at other widths, where the objective
is not comparable with the former fit's: superior 1.07/1.01 -> 1.04/1.02, COP 6.2/8.7 ->
7.8/8.7), the bundled held-out fit unchanged (the new start does not win there).
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import casadi as ca
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))


def key_str(key: tuple) -> str:
    return "/".join(map(str, key))


def synthetic_stances():
    from gc_ocp.estimation.synthetic import default_truth, nominal_points, synthetic_stance

    rng = np.random.default_rng(3)
    truth = default_truth()
    sts = []
    for side, t_off in (("left", 0.0), ("right", 0.55)):
        d = rng.normal(size=(5, 3))
        d *= (rng.uniform(0, 0.008, 5) / np.linalg.norm(d, axis=1))[:, None]
        for t0 in (0.0, 1.1):
            sts.append(
                synthetic_stance(
                    side, truth, nominal_points(side) + d, t0=t0 + t_off, sink=0.010, rng=rng
                )
            )
    return sts


def stance_arrays(prefix: str, sts) -> dict:
    out = {}
    for i, st in enumerate(sts):
        p = f"{prefix}/stance{i}/"
        f = st.foot
        out[p + "time"] = st.time
        out[p + "hindfoot_pose"] = f.hindfoot_pose
        out[p + "toes_pose"] = f.toes_pose
        out[p + "hindfoot_twist"] = f.hindfoot_twist
        out[p + "toes_twist"] = f.toes_twist
        out[p + "points_local"] = f.points_local
        out[p + "measured"] = st.measured
        out[p + "in_contact"] = st.in_contact
        out[p + "reference_point"] = st.reference_point
        out[p + "scalars"] = np.array([st.ground_height, st.body_weight, st.height])
        out[p + "belt_velocity"] = st.belt_velocity
        out[p + "names"] = np.array([st.trial, st.side, st.label])
    out[f"{prefix}/n_stances"] = np.array(len(sts))
    return out


def derivative_pins(prefix: str, sts, seed: int) -> dict:
    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.problem import build_estimation

    pb = build_estimation(sts, full_model())
    b = pb.builder
    x = pb.x0 + 0.05 * np.random.default_rng(seed).normal(size=pb.x0.size)
    f = ca.Function("pin", [pb.x], [pb.objective, pb.gradient, pb.hessian])
    J, g, H = (np.asarray(a) for a in f(x))
    keys = [s["key"] for s in b.specs]
    return {
        f"{prefix}/x": x,
        f"{prefix}/objective": np.array(float(J.ravel()[0])),
        f"{prefix}/gradient": g.ravel(),
        f"{prefix}/hessian": H,
        f"{prefix}/keys": np.array([key_str(k) for k in keys]),
        f"{prefix}/starts": np.array([b._index[k].start for k in keys]),
        f"{prefix}/sizes": np.array([b._index[k].stop - b._index[k].start for k in keys]),
    }


def bundled_stances():
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.stance import stance_data

    t = load_trial()
    kin = compute_kinematics(t)
    return [stance_data(t, kin, s, 0.03, 5) for s in t.stances], (t, kin)


def fit_figures(rep) -> dict:
    r = rep.result
    d = {"objective": r.objective, "rms": r.rms, "cop_rms_mm": r.cop_rms_mm, "status": r.status}
    if rep.heldout is not None:
        d["heldout"] = {
            "label": rep.heldout_label,
            "objective": rep.heldout.objective,
            "rms": rep.heldout.rms,
            "cop_rms_mm": rep.heldout.cop_rms_mm,
        }
    return d


def main(fits_only: bool = False) -> None:
    """Write both pin files; with ``fits_only`` (``--fits-only``) only ``fit_pins.json`` (the
    derivative pins do not depend on how a fit starts)."""
    from test_estimation import _real

    from gc_ocp.workflow.fitting import fit

    if not fits_only:
        write_derivative_pins()
    figs = {"bundled_holdout": fit_figures(fit([bundled_stances()[1]], holdout="right@0.407"))}
    for name in ("plugingait", "rajagopal", "gait2392"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            figs[name] = fit_figures(fit([_real(name)]))
        print(name, figs[name]["objective"], flush=True)
    (HERE / "fit_pins.json").write_text(json.dumps(figs, indent=1, sort_keys=True) + "\n")


def write_derivative_pins() -> None:
    arrays = {}
    syn = synthetic_stances()
    arrays.update(stance_arrays("synthetic", syn))
    arrays.update(derivative_pins("synthetic", syn, 4))
    real, _ = bundled_stances()
    arrays.update(stance_arrays("bundled", real))
    arrays.update(derivative_pins("bundled", real, 5))
    np.savez_compressed(HERE / "estimator_pins.npz", **arrays)


def rewrite_derivative_values() -> None:
    """``--values-only``: the objective, gradient and Hessian of today's full model at the
    pinned decision vector on the *stored* stances (inputs, x and variable layout kept): for a
    deliberate change of the model's expression, so that the pins keep guarding every later
    refactor from the same inputs."""
    from test_pins import _permutation, _problem, _stances

    old = dict(np.load(HERE / "estimator_pins.npz", allow_pickle=False))
    for prefix in ("synthetic", "bundled"):
        stances = _stances(old, prefix)
        pb, index = _problem(stances)
        perm = _permutation(old, prefix, index, stances)
        x = np.empty(perm.size)
        x[perm] = old[f"{prefix}/x"]
        f = ca.Function("pin", [pb.x], [pb.objective, pb.gradient, pb.hessian])
        J, g, H = (np.asarray(a) for a in f(x))
        print(prefix, float(old[f"{prefix}/objective"]), "->", float(J.ravel()[0]), flush=True)
        old[f"{prefix}/objective"] = np.array(float(J.ravel()[0]))
        old[f"{prefix}/gradient"] = g.ravel()[perm]
        old[f"{prefix}/hessian"] = H[np.ix_(perm, perm)]
    np.savez_compressed(HERE / "estimator_pins.npz", **old)


if __name__ == "__main__":
    import sys

    if "--values-only" in sys.argv[1:]:
        rewrite_derivative_values()
    else:
        main(fits_only="--fits-only" in sys.argv[1:])
