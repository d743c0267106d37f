"""Where work runs (``gc_ocp.execution``): the start methods of a local cluster, and what a
script that forgets the main guard is told."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from gc_ocp.execution import START_METHODS, start_method

ROOT = Path(__file__).resolve().parents[1]


def test_the_start_method_is_the_first_the_platform_has_and_a_wrong_one_is_named():
    have = multiprocessing.get_all_start_methods()
    assert start_method() == next(m for m in START_METHODS if m in have)
    for m in have:
        if m in START_METHODS:
            assert start_method(m) == m
    with pytest.raises(ValueError, match="threads.*use one of forkserver, spawn, fork"):
        start_method("threads")


@pytest.mark.skipif(
    "forkserver" not in multiprocessing.get_all_start_methods(), reason="no forkserver here"
)
def test_a_script_without_the_main_guard_is_told_to_add_it(tmp_path):
    """A script that starts a local cluster at module level: its workers import it again and
    fail to start; the error names the script and the guard (not only Dask's "Nanny failed to
    start"). The same script under the guard runs its task."""
    body = """
        from gc_ocp.execution import dask_client
        {guard}
            with dask_client(workers=1) as c:
                print("sum", c.submit(sum, [1, 2]).result())
    """
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = {}
    for name, guard in (("bare", "if True:"), ("guarded", 'if __name__ == "__main__":')):
        script = tmp_path / f"{name}.py"
        script.write_text(textwrap.dedent(body.format(guard=guard)))
        out[name] = subprocess.run(
            [sys.executable, str(script)],
            capture_output=True,
            text=True,
            env=env,
            cwd=tmp_path,
            timeout=300,
        )
    bare, guarded = out["bare"], out["guarded"]
    assert bare.returncode != 0
    assert "InputError" in bare.stderr
    assert str(tmp_path / "bare.py") in bare.stderr
    assert 'if __name__ == "__main__":' in bare.stderr
    assert guarded.returncode == 0, guarded.stderr[-2000:]
    assert "sum 3" in guarded.stdout


def _size_and_tag(big, tag):
    return big.size, tag


def test_arguments_every_task_shares_go_to_the_cluster_once():
    """``shared_once``: on a Dask executor, an argument that every call shares (the same
    object) becomes one scattered future, the others stay as they are, and the tasks get the
    same values as run here; a plain executor's calls are left unchanged."""
    from concurrent.futures import ThreadPoolExecutor

    import numpy as np
    from distributed import Client, Future, LocalCluster

    from gc_ocp.diagnosis.execution import run_tasks, shared_once

    big = np.zeros(1_000_000)  # 8 MB: what a null's shared inputs are like
    calls = [(big, k) for k in range(4)]
    with ThreadPoolExecutor(2) as pool:
        assert shared_once(pool, calls) == calls
    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
        ) as cl,
        Client(cl) as client,
    ):
        ex = client.get_executor()
        sent = shared_once(ex, calls)
        assert all(isinstance(c[0], Future) for c in sent)
        assert len({c[0].key for c in sent}) == 1  # one copy for every task
        assert [c[1] for c in sent] == [0, 1, 2, 3]
        assert run_tasks(_size_and_tag, calls, ex) == [(big.size, k) for k in range(4)]


MADE: list[int] = []


def _slow_tag(k: int, n: int) -> int:
    import time

    MADE.append(k)
    time.sleep(0.002 * (n - k))  # the later calls end first
    return k


def test_a_stop_looks_at_the_first_results_in_order_and_makes_no_more():
    """``run_tasks(stop=...)``: the stop is asked with the first ``k`` results in the calls'
    order (``k`` a multiple of ``look``, whichever task ended first), and when it says yes
    exactly those are returned and no other call is made, here and on a pool; without a yes
    every result is."""
    from concurrent.futures import ThreadPoolExecutor

    from gc_ocp.diagnosis.execution import run_tasks

    n = 20
    calls = [(k, n) for k in range(n)]
    seen = []

    def stop(out):
        seen.append(list(out))
        return len(out) >= 8

    MADE.clear()
    assert run_tasks(_slow_tag, calls, None, stop, look=4) == list(range(8))
    assert seen == [list(range(4)), list(range(8))] and sorted(MADE) == list(range(8))
    seen.clear()
    MADE.clear()
    with ThreadPoolExecutor(2) as pool:
        assert run_tasks(_slow_tag, calls, pool, stop, look=4) == list(range(8))
        assert seen == [list(range(4)), list(range(8))] and sorted(MADE) == list(range(8))
        assert run_tasks(_slow_tag, calls, pool, lambda out: False, look=4) == list(range(n))
        # progress: told after every result, in order, of all the calls planned
        told = []
        run_tasks(_slow_tag, calls, pool, stop, look=4, progress=lambda k, m: told.append((k, m)))
        assert told == [(k, n) for k in range(1, 9)]
    told.clear()
    run_tasks(_slow_tag, calls[:3], None, progress=lambda k, m: told.append((k, m)))
    assert told == [(1, 3), (2, 3), (3, 3)]
