"""Base + each candidate effect on real walking, and what building and solving them costs.

Usage::

    PYTHONPATH=. python benchmarks/effects.py            # the three shared trials (~10-20 min)
    PYTHONPATH=. python benchmarks/effects.py --quick    # the bundled trial only

For every trial: the base model (``base_model()``), base + each effect of ``EFFECTS`` that is
registered and not already in the base, and the bare seed model with and without the two
registration effects (``sole_geometry``, ``kinematic_correction``), each fitted with
``gc_ocp.fit`` (LLS start, two starts) with one stance held out (the last stance of the foot
with most stances; the existing protocol: contact parameters fixed, pose correction
re-estimated under its prior). Printed: in-sample and held-out RMS per channel (% BW, % BW x H;
mean of the feet), the objective, the number of free variables and the time.

Cost: the whole set is run twice on the first trial, first with an empty compile cache (cold:
every configuration compiles its per-frame derivatives to C once) and then warm (cache on disk,
in-memory caches cleared), in the same process. Output markdown goes to stdout.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

CHANNELS = (
    ("anterior_force_pct_bw", "Fx"),
    ("superior_force_pct_bw", "Fz"),
    ("lateral_force_pct_bw", "Fy"),
    ("anteroposterior_torque_pct_bwh", "Mx"),
    ("mediolateral_torque_pct_bwh", "My"),
    ("longitudinal_torque_pct_bwh", "Mz"),
)


def configurations():
    from gc_ocp.estimation import EFFECTS, REGISTRY, bare_seed_model, base_model, model_from_names

    base = base_model()
    have = {type(c) for c in base}
    out = [("base", base)]
    for e in EFFECTS:
        if e in REGISTRY and REGISTRY[e] not in have:
            out.append((f"base + {e}", model_from_names([e], base=base)))
    seed = bare_seed_model()
    out.append(("bare seed", seed))
    for e in ("sole_geometry", "kinematic_correction"):
        out.append((f"bare seed + {e}", model_from_names([e], base=seed)))
    return out


def trials(quick: bool):
    from test_estimation import _real

    names = ["plugingait"] if quick else ["plugingait", "rajagopal", "gait2392"]
    return [(n, _real(n)) for n in names]


def holdout_label(trial) -> str | None:
    """The last stance of the foot with most stances, or None when no foot has two (then only
    in-sample figures: a held-out stance needs another stance of its foot to fit on)."""
    sides = [s.side for s in trial.stances]
    side = max(set(sides), key=sides.count)
    if sides.count(side) < 2:
        return None
    last = [s for s in trial.stances if s.side == side][-1]
    return f"{trial.name}:{last.label}"


def mean_rms(rms: dict) -> list[float]:
    return [float(np.mean([rms[s][c] for s in rms])) for c, _ in CHANNELS]


def run_all(name, tk, configs, out_rows, say):
    from gc_ocp.workflow import fit

    label = holdout_label(tk[0])
    total = 0.0
    base_result = None
    for cname, model in configs:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                # a base + effect fit also starts from the base's solution (the effect at its
                # neutral value), so that it cannot end above the model it extends
                start = base_result if cname.startswith("base +") else None
                rep = fit([tk], model=model, holdout=label, start=start)
            except Exception as e:  # a failed configuration is reported, not hidden
                out_rows.append(
                    (name, cname, None, None, None, None, f"{type(e).__name__}: {e}"[:80])
                )
                continue
        dt = time.perf_counter() - t0
        total += dt
        r = rep.result
        if cname == "base":
            base_result = r
        out_rows.append(
            (
                name,
                cname,
                mean_rms(r.rms),
                mean_rms(rep.heldout.rms) if rep.heldout is not None else None,
                r.objective,
                r.n_free,
                f"{dt:.1f} s",
            )
        )
        say(f"  {name:10s} {cname:32s} J = {r.objective:9.1f}  {dt:6.1f} s")
    return total


def clear_memory_caches():
    from gc_ocp.estimation import frame

    frame._frame_model.cache_clear()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="bundled trial only")
    ap.add_argument("--trials", nargs="*", help="subset of plugingait, rajagopal, gait2392")
    args = ap.parse_args()

    def say(s):
        print(s, file=sys.stderr, flush=True)

    configs = configurations()
    rows: list = []
    tr = trials(args.quick)
    if args.trials:
        tr = [t for t in tr if t[0] in args.trials]
    cold_dir = tempfile.mkdtemp(prefix="gc_ocp_cold_")
    old = os.environ.get("GC_OCP_CACHE_DIR")
    os.environ["GC_OCP_CACHE_DIR"] = cold_dir
    clear_memory_caches()
    say(f"cold run ({len(configs)} configurations, empty compile cache {cold_dir})")
    cold = run_all(tr[0][0], tr[0][1], configs, [], say)
    clear_memory_caches()
    say("warm run (compiled libraries on disk, in-memory caches cleared)")
    warm = run_all(tr[0][0], tr[0][1], configs, rows, say)
    if old is None:
        os.environ.pop("GC_OCP_CACHE_DIR")
    else:
        os.environ["GC_OCP_CACHE_DIR"] = old
    for name, tk in tr[1:]:
        run_all(name, tk, configs, rows, say)

    print(
        f"# Candidate effects on real walking (gc_ocp benchmarks/effects.py{' --quick' if args.quick else ''})\n"
    )
    print(
        f"Cost of building and solving all {len(configs)} configurations for one trial "
        f"({tr[0][0]}, fit() with two starts and a held-out stance each): cold (empty compile "
        f"cache) {cold:.0f} s, warm {warm:.0f} s.\n"
    )
    head = " | ".join(c for _, c in CHANNELS)
    print(f"| trial | model | in-sample {head} | held-out {head} | J | free | time |")
    print("|---|---|" + "---|" * (2 * len(CHANNELS) + 3))
    for name, cname, ins, held, J, nf, t in rows:
        if ins is None:
            print(f"| {name} | {cname} | failed: {t} |" + " |" * (2 * len(CHANNELS) + 2))
            continue
        a = " | ".join(f"{v:.2f}" for v in ins)
        b = (
            " | ".join(f"{v:.2f}" for v in held)
            if held is not None
            else " | ".join(["n/a"] * len(CHANNELS))
        )
        print(f"| {name} | {cname} | {a} | {b} | {J:.1f} | {nf} | {t} |")
    print("\nRMS: mean of the two feet; forces in % BW, torques in % BW x height.")


if __name__ == "__main__":
    main()
