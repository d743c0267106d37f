"""What a diagnosis's local Dask cluster costs before its first fit, by how its workers start:
spawned, forked from a server that preloads gc_ocp (the package's default), or forked from
this process (issue 24; ``gc_ocp.execution.dask_client(start=...)``).

Usage::

    PYTHONPATH=. python benchmarks/dask_start.py [--repeats 3]

The parent does what a diagnosis has done before its first round: it imports gc_ocp and builds
the base model's estimation problem on the bundled trial (its per-frame functions derived and
loaded compiled). Then, for each start method: the time to a ready cluster of two
single-threaded workers, and the time of the first two tasks, each building the same problem
in a worker (what a candidate's first fit pays before solving). Medians of ``--repeats`` runs,
both methods measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import time


def first_task(_: int) -> float:
    """Build the base model's problem on the bundled trial: seconds."""
    t = time.perf_counter()
    from gc_ocp.bench.recovery import bundled_base_truth
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.components import base_model

    stances, _ = bundled_base_truth()
    build_estimation(stances, base_model())
    return time.perf_counter() - t


def measure(start: str) -> tuple[float, float]:
    from gc_ocp.execution import dask_client

    t0 = time.perf_counter()
    with dask_client(workers=2, start=start) as client:
        client.wait_for_workers(2)
        t1 = time.perf_counter()
        ex = client.get_executor()
        list(ex.map(first_task, range(2)))
        t2 = time.perf_counter()
    return t1 - t0, t2 - t1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    t = time.perf_counter()
    first_task(0)  # the parent, as before a diagnosis's first round
    print(f"parent: gc_ocp imported and the base problem built in {time.perf_counter() - t:.1f} s")
    rows = {}
    for start in ("spawn", "forkserver", "fork"):
        runs = [measure(start) for _ in range(args.repeats)]
        if start == "forkserver":
            rows["forkserver, first cluster of the session"] = runs[0]
            runs = runs[1:] or runs
        rows[start] = (
            statistics.median(r[0] for r in runs),
            statistics.median(r[1] for r in runs),
        )
    print("\n| workers started by | cluster ready [s] | first two tasks [s] | total [s] |")
    print("|---|---|---|---|")
    for name, (a, b) in rows.items():
        print(f"| {name} | {a:.1f} | {b:.1f} | {a + b:.1f} |")
    s, f = (sum(rows[k]) for k in ("spawn", "forkserver"))
    print(f"\nForkserver against spawned: {s - f:.1f} s less before the first fit ({s / f:.1f}x).")


if __name__ == "__main__":
    main()
