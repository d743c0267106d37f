"""A second kind of "none" case for the decision rule (issue 22): data of the registered truth
itself (inside the model, no mismatch, no effect) with little or no plate noise.

The registered truth puts some sole offsets 4-5 prior sigmas from their prior mean, so the
fitted base misfits it a little, systematically, and a flexible candidate (damping above all)
absorbs part of that misfit; on replicates of the fitted base it does not. The calibrated test
alone named damping on such data (``docs/diagnosis.md``, Decision rule); the rule's effect-size
floor is what rejects it. This script makes those cases for a motion and writes them in the
withheld-effect benchmark's format (``DIR/confusion.json``, truth "none"), so that
``benchmarks/rule_variants.py`` scores every floor on them beside the mismatch "none" cases.

    PYTHONPATH=. .venv/bin/python benchmarks/prior_bias_none.py --out DIR [--trial FILE ...]

Cases: plate noise 0 % BW (one case) and 0.25, 0.5, 1 % BW (two seeds each); the diagnosis as
the benchmark runs it (blind, ``max_effects=1``, the package's default null). Each case is
written when done (``--resume`` keeps the finished ones).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from gc_ocp.bench.summary import summarize
from gc_ocp.bench.truth import _source
from gc_ocp.bench.withheld import CASE_ROW_KEYS
from gc_ocp.diagnosis import diagnose_stances
from gc_ocp.diagnosis.diagnose import candidate_names
from gc_ocp.estimation.components import base_model
from gc_ocp.estimation.synthetic import simulate

CASES = [(0.0, 0), (0.25, 0), (0.5, 0), (1.0, 0), (0.25, 1), (0.5, 1), (1.0, 1)]
"""(plate noise [% BW], seed); ``--cases N`` runs the first N (the first four: every level)."""


def _write(path: Path, result: dict) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(result, f, indent=1)
    os.replace(tmp, path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--trial", action="append", default=None)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--cases", type=int, default=len(CASES))
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "confusion.json"
    stances, truth = _source(tuple(a.trial) if a.trial else None)
    stances = list(stances)
    names = candidate_names(base_model())
    cases = json.loads(path.read_text())["cases"] if a.resume and path.exists() else []
    done = {c["seed"] for c in cases}
    for k, (noise, seed) in enumerate(CASES[: a.cases]):
        if k in done:
            continue
        t0 = time.perf_counter()
        data = simulate(stances, truth, np.random.default_rng(1000 + k), plate_noise_pct_bw=noise)
        t1 = time.perf_counter()
        d = diagnose_stances(data, max_effects=1, seed=seed)
        answer = d.selected[0] if d.selected else "none"
        cases.append(
            {
                "truth": "none",
                "magnitude": "-",
                "seed": k,
                "plate_noise_pct_bw": noise,
                "answer": answer,
                "correct": answer == "none",
                "ranking": [
                    {key: v for key, v in r.to_json().items() if key in CASE_ROW_KEYS}
                    for r in d.ranking
                ],
                "seconds_generate": t1 - t0,
                "seconds_diagnose": time.perf_counter() - t1,
            }
        )
        result = {
            "settings": {
                "base": "registered",
                "candidates": names,
                "kind": "prior-biased none: data of the registered truth, plate noise only",
                "trials": a.trial,
            },
            "summary": summarize(cases, [*names, "none"]),
            "cases": cases,
            "seconds": {
                "cases_total": sum(c["seconds_generate"] + c["seconds_diagnose"] for c in cases)
            },
        }
        _write(path, result)
        print(f"[{k + 1}/{len(CASES)}] noise {noise} % BW -> {answer}", flush=True)


if __name__ == "__main__":
    main()
