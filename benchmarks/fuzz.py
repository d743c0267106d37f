"""Fuzz benchmark: many damaged copies of a real trial through ``gc-ocp info`` and ``gc-ocp fit``.

Usage::

    PYTHONPATH=. python benchmarks/fuzz.py [--info 300] [--fit 40] [--seed 0]

Damages (``tests/fuzz_damage.py``): truncation of either file, NaN runs in a marker, zero runs
in the forces, junk cells, markers scaled x1000 / x0.001, swapped or rotated axes, force timing
shifted by up to +-0.3 s, duplicated and missing columns. Counted: inputs tried, tracebacks or
internal errors (exit 3), and silent results (a fit that exits 0 naming no problem while its
figures leave the clean fit's uncertainty; ``tests/test_fuzz.py::silent_and_wrong``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from fuzz_damage import KINDS, damage  # noqa: E402
from test_fuzz import MASS, MOT, TRC, run, silent_and_wrong  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--info", type=int, default=300)
    ap.add_argument("--fit", type=int, default=40)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    exits: Counter = Counter()
    crashes, silent = [], []
    with tempfile.TemporaryDirectory() as tmp:
        clean_out = Path(tmp) / "clean"
        code, err = run(
            ["fit", str(TRC), "--grf", str(MOT), "--mass", MASS, "--out", str(clean_out)]
        )
        assert code == 0, err
        clean = json.loads((clean_out / "fit.json").read_text())
        for i in range(args.info + args.fit):
            kind = KINDS[rng.integers(len(KINDS))]
            u = tuple(float(v) for v in rng.uniform(0, 1, 3))
            d = Path(tmp) / f"case{i}"
            trc, mot = damage(TRC, MOT, kind, u, d / "in")
            cmd = "info" if i < args.info else "fit"
            argv = [cmd, str(trc), "--grf", str(mot), "--mass", MASS]
            if cmd == "fit":
                argv += ["--out", str(d / "out")]
            code, err = run(argv)
            exits[(cmd, code)] += 1
            if code not in (0, 1, 2) or "Traceback" in err or "internal error" in err:
                crashes.append((cmd, kind, u, err.strip().splitlines()[-1] if err.strip() else ""))
            elif cmd == "fit" and code == 0:
                res = json.loads((d / "out" / "fit.json").read_text())
                if silent_and_wrong(res, clean):
                    silent.append((kind, u))
            print(
                f"{i + 1}/{args.info + args.fit} {cmd} {kind}: exit {code}",
                file=sys.stderr,
                flush=True,
            )
    print(
        f"# Fuzz: {args.info} damaged inputs through info, {args.fit} through fit (seed {args.seed})\n"
    )
    print(
        "| command | exit 0 | exit 1 (solve failed) | exit 2 (bad input named) | exit 3 (internal) |"
    )
    print("|---|---|---|---|---|")
    for cmd in ("info", "fit"):
        print(f"| {cmd} | " + " | ".join(str(exits[(cmd, c)]) for c in (0, 1, 2, 3)) + " |")
    print(f"\ntracebacks / internal errors: {len(crashes)}")
    for c in crashes:
        print(f"  - {c}")
    print(f"silent results (fit exit 0, no new flag or check, figures off): {len(silent)}")
    for s in silent:
        print(f"  - {s}")


if __name__ == "__main__":
    main()
