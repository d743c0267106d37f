"""The estimator's per-frame functions compiled to C: same values, cache, and graceful fallback."""

from __future__ import annotations

import shutil

import casadi as ca
import numpy as np
import pytest

from gc_ocp.estimation import compiled as cmod

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
    from gc_ocp.estimation import build_estimation, full_model
    from gc_ocp.estimation.frame import _derivatives
    from gc_ocp.estimation.synthetic import default_truth, synthetic_stance

    st = synthetic_stance("left", default_truth(), sink=0.01)
    pb = build_estimation([st], full_model())
    block = pb.blocks[0]
    fm = block.fm
    assert fm.grad.class_name() == "External" and fm.hess.class_name() == "External"
    g, h, _ = _derivatives(fm.frame, fm.data.size, fm.slots.size)
    x = pb.x0 + 0.1 * np.random.default_rng(0).normal(size=pb.x0.size)
    D, Y = block.D, block.Y(x)
    for a, b in ((g, fm.grad), (h, fm.hess)):
        ref = np.asarray(a.map(block.T)(D, Y))
        got = np.asarray(b.map(block.T)(D, Y))
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
