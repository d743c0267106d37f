"""The estimator's per-frame functions compiled to C: same values, cache, and graceful fallback."""

from __future__ import annotations

import shutil

import casadi as ca
import numpy as np
import pytest

from gc_ocp.estimation import compiled as cmod
from gc_ocp.estimation.problem import N_D, N_Y, _contact_frame_function, _frame_cost_derivatives

needs_cc = pytest.mark.skipif(
    shutil.which("gcc") is None and shutil.which("cc") is None,
    reason="no C compiler on this machine",
)


def _small() -> list[ca.Function]:
    x = ca.SX.sym("x", 3)
    return [
        ca.Function("gc_test_f", [x], [ca.sin(x[0]) * x[1] + ca.exp(x[2])]),
        ca.Function("gc_test_g", [x], [ca.vertcat(x[0] * x[1], ca.sqrt(x[2] ** 2 + 1))]),
    ]


@needs_cc
def test_compiled_frame_derivatives_equal_the_sx_ones():
    """Generated C evaluates the same expression graph in the same order, so the results agree to
    a few ulps of the largest entry (1e-12 relative leaves room for compiler reassociation)."""
    _, g_c, h_c = cmod.frame_functions(5e-4, 0.05)
    assert g_c.class_name() == "External" and h_c.class_name() == "External"
    g, h = _frame_cost_derivatives(_contact_frame_function(5e-4, 0.05))
    rng = np.random.default_rng(0)
    D = rng.normal(size=(N_D, 40))
    D[42:48] = 50.0  # inverse sigmas of a typical stance
    Y = 0.01 * rng.normal(size=(N_Y, 40))
    Y[27:32] = np.log(3e5)  # log k
    Y[32], Y[33], Y[34] = 1.5, 1.0, 0.8  # n, c, mu
    for a, b in ((g, g_c), (h, h_c)):
        ref = np.asarray(a.map(40)(D, Y))
        got = np.asarray(b.map(40)(D, Y))
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()


@needs_cc
def test_cache_is_reused(tmp_path, monkeypatch):
    monkeypatch.setenv("GC_OCP_CACHE_DIR", str(tmp_path))
    said: list[str] = []
    f1 = cmod.compiled(_small(), "gc_test_lib", say=said.append)
    libs = list(tmp_path.glob("gc_test_lib-*.so"))
    assert len(said) == 1 and len(libs) == 1
    mtime = libs[0].stat().st_mtime_ns
    f2 = cmod.compiled(_small(), "gc_test_lib", say=said.append)
    assert len(said) == 1 and libs[0].stat().st_mtime_ns == mtime  # not rebuilt
    assert float(f1[0](np.array([0.3, 2.0, 0.1]))) == float(f2[0](np.array([0.3, 2.0, 0.1])))
    assert not list(tmp_path.glob("tmp*"))  # no leftovers of the build directory


def test_disabled_by_environment(monkeypatch):
    monkeypatch.setenv("GC_OCP_COMPILE", "0")
    fs = _small()
    out = cmod.compiled(fs, "gc_test_lib", say=lambda s: pytest.fail("must not compile"))
    assert [f.class_name() for f in out] == ["SXFunction", "SXFunction"]


def test_failing_compiler_falls_back_with_a_warning(tmp_path, monkeypatch):
    if shutil.which("false") is None:
        pytest.skip("no `false` command")
    monkeypatch.setenv("GC_OCP_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "false")  # a "compiler" that always fails
    with pytest.warns(UserWarning, match="GC_OCP_COMPILE=0"):
        out = cmod.compiled(_small(), "gc_test_fail", say=lambda s: None)
    assert [f.class_name() for f in out] == ["SXFunction", "SXFunction"]
    assert not list(tmp_path.glob("*.so"))


def test_missing_compiler_falls_back_with_a_warning(monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler-gc-ocp")
    with pytest.warns(UserWarning, match="No C compiler"):
        out = cmod.compiled(_small(), "gc_test_none", say=lambda s: None)
    assert out[0].class_name() == "SXFunction"


@needs_cc
def test_unwritable_cache_falls_back_to_the_temporary_directory(tmp_path, monkeypatch):
    import tempfile

    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where the cache directory should be")
    monkeypatch.setenv("GC_OCP_CACHE_DIR", str(blocker / "cache"))
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmpdir))
    out = cmod.compiled(_small(), "gc_test_fallback", say=lambda s: None)
    assert out[0].class_name() == "External"
    assert list(tmpdir.glob("gc_ocp-*/gc_test_fallback-*.so"))
