"""Diagnosis speed: a full diagnosis of the bundled trial, cold and warm, and where the time goes.

Run:  PYTHONPATH=. python benchmarks/diagnosis_speed.py [--skip-cold] [--subject FILE ...]
      [--static FILE]

1. Bundled trial (3 stances, 2 held-out folds), default base ("registered"), every candidate of
   the library (7), forward selection to the end:
   * cold: a fresh compile cache (``GC_OCP_CACHE_DIR`` set to an empty folder), so every new
     configuration is generated as C and compiled (once per machine in real use);
   * warm: the same cache again, with 1 worker process and with the default workers (both cores);
   * baseline measured in the same run: one ``fit()`` of the base model on every stance (two
     starts), so the diagnosis's cost is printed as a multiple of a plain fit.
   Each run is a separate Python process (a clean compile cache and no shared state); its
   breakdown: the base's fits (all stances + each fold), each candidate's evaluation per round,
   the calibrated null (its mismatch draws, each a refit of the parent) and the rest
   (bootstrap, ranking, residual maps).
2. Several trials of one subject (``--subject FILE FILE FILE``, e.g. three walking trials of the
   BTS subject in ``../shared/data/bts_unipd_5trials``): cold (a fresh compile cache of its own)
   then warm, default workers; ``--static FILE``: with the subject's static trial (the BTS
   subject's ``Static1.c3d``: its registration changes the answer from none to damping, so that
   the time of a diagnosis that names an effect is measured).

Targets (issue 13): <= 60 s warm for the bundled trial, <= 120 s for three trials of a subject,
on a 2-core machine; issue 22 keeps the second with the calibrated null's refits included. Machines here are noisy: read ratios, not absolute seconds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def child(args) -> None:
    """One diagnosis (or one fit) in this process; prints a JSON line of timings."""
    import warnings

    warnings.simplefilter("ignore")
    import gc_ocp
    from gc_ocp.diagnosis import diagnose

    if args.trials:
        pairs = []
        for p in args.trials:
            t = gc_ocp.load_trial(p)
            static = gc_ocp.load_static(args.static, t) if args.static else None
            pairs.append((t, gc_ocp.compute_kinematics(t, static=static)))
    else:
        t = gc_ocp.load_trial()
        pairs = [(t, gc_ocp.compute_kinematics(t))]
    t0 = time.perf_counter()
    if args.mode == "fit":
        from gc_ocp.estimation.components import base_model

        gc_ocp.fit(pairs, model=base_model())
        print(json.dumps({"total": time.perf_counter() - t0}))
        return
    d = diagnose(pairs, workers=args.workers)
    total = time.perf_counter() - t0
    evs = d.evaluations
    print(
        json.dumps(
            {
                "total": total,
                "diagnosis_seconds": d.seconds,
                "base": evs["base"].seconds,
                "candidates": {k: v.seconds for k, v in evs.items() if k != "base"},
                "null": sum(c.get("seconds", 0.0) for c in d.calibration),
                "null_draws": [c.get("mismatch_draws") for c in d.calibration],
                "rounds": len(d.rounds),
                "selected": d.selected,
                "stances": len(d.folds["stances"]),
                "folds": d.folds["n"],
            }
        )
    )


def run(mode: str, cache: str, workers: int | None = None, trials=(), static=None) -> dict:
    env = dict(os.environ, GC_OCP_CACHE_DIR=cache)
    cmd = [sys.executable, __file__, "--child", mode]
    if workers is not None:
        cmd += ["--workers", str(workers)]
    for t in trials:
        cmd += ["--trial", str(t)]
    if static is not None:
        cmd += ["--static", str(static)]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise SystemExit(f"child failed:\n{out.stderr[-3000:]}")
    d = json.loads(out.stdout.strip().splitlines()[-1])
    d["process"] = time.perf_counter() - t0
    return d


def report(name: str, r: dict, fit_s: float) -> None:
    print(
        f"{name:<34} {r['diagnosis_seconds']:7.1f} s  ({r['diagnosis_seconds'] / fit_s:5.1f} x a fit; "
        f"process {r['process']:.0f} s; {r['stances']} stances, {r['folds']} folds, "
        f"{r['rounds']} rounds, selected {r['selected'] or 'none'})"
    )
    cand = r["candidates"]
    rest = r["diagnosis_seconds"] - r["base"] - r.get("null", 0.0)
    rest -= sum(cand.values()) if r.get("serial") else 0
    print(f"    base (all stances + folds): {r['base']:.1f} s")
    if "null" in r:  # the calibrated null of every round: its mismatch draws' refits
        print(
            f"    calibrated null ({len(r['null_draws'])} rounds, draws {r['null_draws']}): {r['null']:.1f} s"
        )
    for k, v in sorted(cand.items(), key=lambda kv: -kv[1])[:6]:
        print(f"    {k:<44} {v:6.1f} s")
    if r.get("serial"):
        print(f"    rest (bootstrap, ranking, maps): {rest:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", choices=["diagnose", "fit"])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--trial", dest="trials", action="append", default=[])
    ap.add_argument("--skip-cold", action="store_true")
    ap.add_argument("--subject", type=Path, nargs="+", default=None)
    ap.add_argument("--static", type=Path, default=None)
    args = ap.parse_args()
    if args.child:
        args.mode = args.child
        child(args)
        return
    if args.skip_cold:  # the machine's own cache (warm after any earlier diagnosis)
        from gc_ocp.estimation.compiled import cache_dir

        cache = str(cache_dir())
        print(f"compile cache: {cache} (the machine's; warm runs only)")
    else:
        cache = tempfile.mkdtemp(prefix="gc_ocp_bench_cache_")
        print(f"compile cache: {cache} (fresh)")
    if not args.skip_cold:
        cold = run("diagnose", cache)
        cold["serial"] = False
    fit_s = run("fit", cache)["total"]
    print(f"baseline: one fit() of the base model on every stance: {fit_s:.1f} s")
    if not args.skip_cold:
        report("bundled, cold (compiles)", cold, fit_s)
    w1 = run("diagnose", cache, workers=1)
    w1["serial"] = True
    report("bundled, warm, 1 worker", w1, fit_s)
    w2 = run("diagnose", cache)
    report("bundled, warm, default workers", w2, fit_s)
    print(f"parallel speed-up (warm): {w1['diagnosis_seconds'] / w2['diagnosis_seconds']:.2f} x")
    if args.subject:
        trials = args.subject
        # the first run compiles this subject's configurations (more stances: other shapes); in
        # a fresh cache of its own unless --skip-cold, so that it is the cold first run
        first_cache = cache if args.skip_cold else tempfile.mkdtemp(prefix="gc_ocp_bench_cache_")
        first = run("diagnose", first_cache, trials=trials, static=args.static)
        what = f"{len(trials)} trials of one subject" + (" + static" if args.static else "")
        if not args.skip_cold:
            report(f"{what}, cold (compiles)", first, fit_s)
        s = run("diagnose", first_cache, trials=trials, static=args.static)
        report(f"{what}, warm", s, fit_s)


if __name__ == "__main__":
    main()
