"""How large is each member of the mismatch family, against the candidate effects' injections?

    python benchmarks/mismatch_sizes.py          # writes benchmarks/mismatch_sizes_output.md

On the bundled motion and its registered truth (``bench.recovery.bundled_base_truth()``), no
plate noise. For every member of :class:`gc_ocp.diagnosis.mismatch.MismatchFamily` (scale 1),
alone, over draws of seeds 0-11:

* **change**: RMS of the change of the force the plate records [% BW] (3 channels pooled, every
  frame of the three stances). For the kinematic members (low-pass, noise and drift) the plate
  is the truth's on the true motion and the change is what the truth predicts from the
  kinematics the fitter sees minus it: the misfit before any registration;
* **left after the base's refit**: the registered base (``base_model()``: law, sole and pose
  registration) fitted to those data (draws 0-2), its in-sample force RMS ``r``, and what the
  member adds to the refit of the unchanged data (``r0``): ``sqrt(r^2 - r0^2)`` [% BW], the part
  the base cannot absorb, which is what could pass for an effect.

The same two numbers at the ends of the continuous members' ranges, and for each candidate
effect at its moderate injection (``bench.truth.injected_values()``; ``sole_geometry`` and
``kinematic_correction`` on the seed base's truth and fitted by the bare seed base, where they
are effects).

**Which candidate takes it**: for the two members the base leaves most of (friction
regularisation, marker low-pass; draws 0-1), each candidate of the registered base added and
fitted from the base's fit (as the diagnosis fits an extension on all stances): the reduction
of the square root of the in-sample objective [%], the diagnosis's kind of score (its
in-sample score is the root of a cost per residual; its threshold is 2 %, in-sample and held
out).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from pathlib import Path

import numpy as np

from gc_ocp.bench import truth as bt
from gc_ocp.bench.recovery import bundled_base_truth
from gc_ocp.diagnosis import mismatch as mm
from gc_ocp.diagnosis.diagnose import candidate_names
from gc_ocp.estimation.components import bare_seed_model, base_model, model_from_names
from gc_ocp.estimation.starts import best_of, estimate, with_lls_start
from gc_ocp.estimation.synthetic import noisy_pose, simulate

HERE = Path(__file__).parent
SEEDS = range(12)
FIT_SEEDS = range(3)


def clean(stances, truth):
    return simulate(stances, truth, np.random.default_rng(0), plate_noise_pct_bw=0.0)


def change(a, b) -> float:
    d = np.concatenate([x.measured[:, :3] - y.measured[:, :3] for x, y in zip(a, b, strict=True)])
    return float(np.sqrt(np.mean(d**2)) / a[0].body_weight * 100)


def fit(data, model, start=None):
    """The model fitted to ``data``: from the seed's LLS, or only from ``start`` (a fit of the
    model it extends)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = with_lls_start(model, data)
        if start is None:
            return estimate(data, model, covariance=False)
        return best_of(data, model, strategies=(), start=start, covariance=False)


def force_rms(result, data) -> float:
    d = np.concatenate([f["model"][:, :3] - f["measured"][:, :3] for f in result.stance_fits])
    return float(np.sqrt(np.mean(d**2)) / data[0].body_weight * 100)


def fit_rms(data, model) -> float:
    return force_rms(fit(data, model), data)


def left(r: float, r0: float) -> float:
    return float(np.sqrt(max(r**2 - r0**2, 0.0)))


def main() -> None:
    t0 = time.perf_counter()
    stances, truth = bundled_base_truth()
    base = clean(stances, truth)
    r0 = fit_rms(base, base_model())
    fam = mm.MismatchFamily()
    zero = mm.MismatchFamily(scale=0.0).draw(np.random.default_rng(0))

    def only(d, *names):
        return dataclasses.replace(zero, **{n: getattr(d, n) for n in names})

    def plate_side(d):  # members the plate records: (changed data, nominal-layout data)
        data = clean(mm.true_motion(stances, d), mm.truth_variant(truth, d))
        data = mm.plate_processing(data, d, np.random.default_rng(1))
        return data, [x.with_foot(s.foot) for x, s in zip(data, stances, strict=True)]

    def seen_side(d):  # kinematic members
        seen = mm.seen_motion(stances, d, np.random.default_rng(1))
        return clean(seen, truth), [x.with_foot(s.foot) for x, s in zip(base, seen, strict=True)]

    members = {
        "penetration smoothing (width x0.5-2, softplus p=0.5)": (
            plate_side,
            ("depth_factor", "depth_form"),
        ),
        "friction regularisation (width x0.5-2, tanh p=0.5)": (
            plate_side,
            ("slip_factor", "slip_form"),
        ),
        "units off the layout (2 mm per axis)": (plate_side, ("unit_offsets",)),
        "plate threshold (none p=0.5, else 5-40 N)": (plate_side, ("threshold_n",)),
        "mains hum (50/60 Hz, 0.5-3 N)": (plate_side, ("hum_frequency_hz", "hum_amplitude_n")),
        "marker low-pass (4-10 Hz)": (seen_side, ("cutoff_hz",)),
        "marker noise + drift (0.25-1 mm; 1-4 mm, 0.25-1 deg)": (
            seen_side,
            ("marker_noise", "drift_translation", "drift_rotation_deg"),
        ),
    }
    rows = []
    for name, (side, fields) in members.items():
        ch, lf = [], []
        for seed in SEEDS:
            d = only(fam.draw(np.random.default_rng(seed)), *fields)
            changed, fitted = side(d)
            ch.append(change(changed, base))
            if seed in FIT_SEEDS:
                lf.append(left(fit_rms(fitted, base_model()), r0))
        rows.append((name, ch, lf))
        print(name, f"{np.median(ch):.2f}", np.round(lf, 2), flush=True)
    # the whole draw as the benchmark applies it to the registered base (the kinematic error
    # is the realism's: no noise or drift of the draw's own)
    ch, lf = [], []
    for seed in SEEDS:
        d = fam.draw(np.random.default_rng(seed)).for_model(base_model()).without_pose_error()
        changed, _ = plate_side(d)
        seen = mm.seen_motion(stances, d, np.random.default_rng(1))
        # the misfit before registration: the plate against the truth's own model on the
        # kinematics the fitter sees
        ch.append(change(changed, clean(seen, truth)))
        if seed in FIT_SEEDS:
            fitted = [x.with_foot(s.foot) for x, s in zip(changed, seen, strict=True)]
            lf.append(left(fit_rms(fitted, base_model()), r0))
    rows.append(("whole draw, registered base (no noise/drift of its own)", ch, lf))

    ends = []
    for name, side, d in (
        (
            "penetration width x2, hyperbola",
            plate_side,
            dataclasses.replace(zero, depth_factor=2.0),
        ),
        (
            "penetration width x0.5, softplus",
            plate_side,
            dataclasses.replace(zero, depth_factor=0.5, depth_form="softplus"),
        ),
        ("slip width x2, algebraic", plate_side, dataclasses.replace(zero, slip_factor=2.0)),
        (
            "slip width x0.5, tanh",
            plate_side,
            dataclasses.replace(zero, slip_factor=0.5, slip_form="tanh"),
        ),
        ("low-pass 4 Hz", seen_side, dataclasses.replace(zero, cutoff_hz=4.0)),
        ("low-pass 10 Hz", seen_side, dataclasses.replace(zero, cutoff_hz=10.0)),
    ):
        changed, fitted = side(d)
        ends.append((name, change(changed, base), left(fit_rms(fitted, base_model()), r0)))
        print(*ends[-1], flush=True)

    takes = []
    cands = candidate_names(base_model())
    for name, side, fields in (
        ("friction regularisation", plate_side, ("slip_factor", "slip_form")),
        ("marker low-pass", seen_side, ("cutoff_hz",)),
    ):
        for seed in range(2):
            d = only(fam.draw(np.random.default_rng(seed)), *fields)
            _, fitted = side(d)
            parent = fit(fitted, base_model())
            red = {}
            for c in cands:
                child = fit(fitted, model_from_names([c], base=base_model()), start=parent)
                red[c] = 100 * (1 - np.sqrt(child.objective / parent.objective))
            what = {f: getattr(d, f) for f in fields}
            takes.append((name, seed, what, red))
            print(name, seed, what, {c: round(v, 1) for c, v in red.items()}, flush=True)

    effects = []
    for eff, values in bt.injected_values().items():
        seed_base = eff in ("sole_geometry", "kinematic_correction")
        sts = bt.motion("seed" if seed_base else "registered", eff)
        fr = bt.base_truth("seed" if seed_base else "registered")
        model = bare_seed_model() if seed_base else base_model()
        b0 = clean(sts, fr)
        e0 = fit_rms(b0, model)
        ch, lf = [], []
        for seed in FIT_SEEDS:
            rng = np.random.default_rng(seed)
            if eff == "kinematic_correction":
                noise, dm, ddeg = values["moderate"]
                seen = mm.drift(sts, dm, ddeg, rng)
                seen = [s.with_foot(noisy_pose(s.foot, noise, rng)) for s in seen]
                ch.append(change(clean(seen, fr), b0))
                data = [x.with_foot(s.foot) for x, s in zip(b0, seen, strict=True)]
            else:
                data = clean(sts, bt.truth_model(eff, "moderate", fr, sts, rng))
                ch.append(change(data, b0))
            if seed == 0:
                lf.append(left(fit_rms(data, model), e0))
        effects.append((eff, values["moderate"], ch, lf, "seed" if seed_base else "registered"))
        print(eff, np.round(ch, 2), np.round(lf, 2), flush=True)

    def rng_(v):
        return f"{np.median(v):.2f} ({min(v):.2f}-{max(v):.2f})"

    lines = [
        "# Mismatch family: the size of each member against the candidate effects",
        "",
        "`python benchmarks/mismatch_sizes.py` (module doc: what is measured). Bundled motion "
        "(3 stances, 63.6 kg), its registered truth, no plate noise; forces in % BW (RMS of 3 "
        f"channels over every frame). Refit of the unchanged data: force RMS {r0:.3f} % BW.",
        "",
        f"| member (scale 1) | change, median (range) over {len(SEEDS)} draws | left after "
        f"the registered base's refit, draws 0-{len(FIT_SEEDS) - 1} |",
        "|---|---|---|",
    ]
    for name, ch, lf in rows:
        lines.append(f"| {name} | {rng_(ch)} | {', '.join(f'{v:.2f}' for v in lf)} |")
    lines += [
        "",
        "| the range's ends | change | left after the base's refit |",
        "|---|---|---|",
    ]
    lines += [f"| {n} | {c:.2f} | {lf:.2f} |" for n, c, lf in ends]
    lines += [
        "",
        "| which candidate takes it: in-sample reduction of sqrt(objective) [%] | "
        + " | ".join(cands)
        + " |",
        "|---|" + "---|" * len(cands),
    ]
    for name, seed, what, red in takes:
        label = ", ".join(
            f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in what.items()
        )
        lines.append(
            f"| {name}, draw {seed} ({label}) | "
            + " | ".join(f"{red[c]:.1f}" for c in cands)
            + " |"
        )
    lines += [
        "",
        "| candidate effect, moderate | value | change (seeds 0-2) | left after the base's "
        "refit (seed 0) | base |",
        "|---|---|---|---|---|",
    ]
    for eff, v, ch, lf, b in effects:
        lines.append(f"| {eff} | {v} | {', '.join(f'{c:.2f}' for c in ch)} | {lf[0]:.2f} | {b} |")
    lines += ["", f"Run time {time.perf_counter() - t0:.0f} s."]
    (HERE / "mismatch_sizes_output.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
