"""Every walking trial of ``../shared/data`` fitted with the estimator of issue 23 beside the one
before it (issue 23's Done means: "not worse on RMS; far fewer flags").

Run:  PYTHONPATH=. python benchmarks/joint_estimator.py [--data ../shared/data] [--only SUBSTR]
      [--correlation]

*Before*: the pose correction with its guessed prior (2 mm, 1 deg) and no marker-noise part.
*Now*: the markers' measured noise modelled (``gc_ocp/marker_noise.py``) and the
pose correction's smooth width estimated from the stances (``gc_ocp/estimation/pose_scale.py``).
Per file, one stance held out (the last one of a foot that has two; none when no foot has):
superior-force RMS [% BW] in sample (mean of the feet) and held out, COP RMS [mm] in sample,
the markers' white noise of the foot segments [mm], the estimated widths, the flags of
corrections beyond 3 sigma of their prior (``prior_exceeded``) and all flags, and the time.

``--correlation``: *before* is today's default (``gc_ocp.fit``), *now* adds the pose
coefficients' knot-to-knot correlation estimated with the widths (``pose_correlation=True``);
the widths column then ends with the estimated correlation one knot apart.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from all_data import WALKING, _load  # noqa: E402


def _holdout(trial) -> str | None:
    by_side: dict = {}
    for s in trial.stances:
        by_side.setdefault(s.side, []).append(s)
    two = [v for v in by_side.values() if len(v) >= 2]
    return two[0][-1].label if two else None


def _row(pairs, kind: str, holdout):
    """kind: "prior" (before issue 23), "default" (``gc_ocp.fit``), "correlation"."""
    import gc_ocp
    from gc_ocp.estimation.components import PoseCorrection

    model = gc_ocp.full_model()
    if kind == "prior":
        model = tuple(
            PoseCorrection(marker_noise=False) if isinstance(c, PoseCorrection) else c
            for c in model
        )
    t0 = time.perf_counter()
    rep = gc_ocp.fit(
        pairs,
        model=model,
        holdout=holdout,
        pose_scale=kind != "prior",
        pose_correlation=kind == "correlation",
    )
    dt = time.perf_counter() - t0
    r = rep.result
    sup = [v["superior_force_pct_bw"] for v in r.rms.values()]
    ho = None if rep.heldout is None else next(iter(rep.heldout.rms.values()))
    flags = r.flags
    return {
        "in": sum(sup) / len(sup),
        "held": None if ho is None else ho["superior_force_pct_bw"],
        "cop": sum(r.cop_rms_mm.values()) / len(r.cop_rms_mm),
        "prior": sum(f["code"] == "prior_exceeded" for f in flags),
        "flags": len(flags),
        "scale": rep.pose_scale,
        "s": dt,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--data", type=Path, default=Path(__file__).parents[1].parent / "shared" / "data"
    )
    ap.add_argument("--only", default="")
    ap.add_argument(
        "--correlation",
        action="store_true",
        help="before: the default; now: the knots' correlation estimated too",
    )
    args = ap.parse_args()
    kinds = ("default", "correlation") if args.correlation else ("prior", "default")
    print(
        "| file | marker noise, foot [mm] | held out | superior RMS in / held out [% BW] | COP [mm] | corrections > 3 sigma (all flags) | widths (mm; deg) | s |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for rel in WALKING:
        if args.only not in rel:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                pairs = [_load(args.data / rel)]
                ho = _holdout(pairs[0][0])
                old = _row(pairs, kinds[0], ho)
                new = _row(pairs, kinds[1], ho)
            except Exception as e:  # a file the fit refuses: say why, go on
                print(f"| {rel} | {type(e).__name__}: {str(e)[:120]} | | | | | | |", flush=True)
                continue
        err = pairs[0][1].info["marker_error"]["white_mm_per_class"]
        foot = ", ".join(
            f"{c} {v:.3f}" for c, v in err.items() if c.startswith(("hindfoot", "toes"))
        )

        def f(v):
            return "-" if v is None else f"{v:.2f}"

        sc = new["scale"]
        widths = (
            "-"
            if sc is None
            else "/".join(f"{v:.1f}" for v in sc.sigma_mm)
            + "; "
            + "/".join(f"{v:.1f}" for v in sc.sigma_deg)
            + ("" if sc.knot_correlation is None else f"; phi {sc.knot_correlation:.2f}")
        )
        print(
            f"| {rel} | {foot} | {ho or '-'} | {f(old['in'])} / {f(old['held'])} -> "
            f"{f(new['in'])} / {f(new['held'])} | {old['cop']:.0f} -> {new['cop']:.0f} | "
            f"{old['prior']} ({old['flags']}) -> {new['prior']} ({new['flags']}) | {widths} | "
            f"{old['s']:.0f} -> {new['s']:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
