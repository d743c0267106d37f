"""Shared test helpers: the three real datasets of ``../shared/data``, loaded with the package's
own loaders (``gc_ocp.io``). Masses come from the OpenSim scale set-ups (not in the files);
heights of the OpenSim subjects are not in the files either and are left to the kinematics'
estimate. Tests needing these data are skipped with a reason when ``../shared/data`` is absent."""

from __future__ import annotations

import functools
import warnings
from pathlib import Path

import pytest

from gc_ocp.trial import Trial

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"  # ../shared beside the repo
RAJ = DATA / "opensim_rajagopal_overground"
G23 = DATA / "opensim_gait2392_treadmill"
G2392_SURFACE = -0.0075  # treadmill surface: the COP of the MOT file lies at py = -7.5 mm


def _need_data() -> None:
    if not DATA.is_dir():
        pytest.skip(f"real datasets not found at {DATA} (../shared/data beside the repository)")


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # clipped-stance warnings are tested in test_io.py
        return fn(*a, **kw)


@functools.cache
def c3d_trial() -> Trial:
    from gc_ocp.io import load_trial

    _need_data()
    return load_trial(DATA / "plugingait_overground/test_small.c3d")


@functools.cache
def rajagopal_trial() -> Trial:
    from gc_ocp.io import load_trial

    _need_data()
    return load_trial(RAJ / "motion_capture_walk.trc", grf=RAJ / "grf_walk.mot", mass=85.07)


@functools.cache
def rajagopal_static() -> Trial:
    from gc_ocp.io import load_static

    return load_static(RAJ / "static_walk_1.trc", rajagopal_trial())


@functools.cache
def gait2392_trial() -> Trial:
    from gc_ocp.io import load_trial

    _need_data()
    return _quiet(
        load_trial, G23 / "subject01_walk1.trc", grf=G23 / "subject01_walk1_grf.mot", mass=72.6
    )


@functools.cache
def gait2392_static() -> Trial:
    from gc_ocp.io import load_static

    return load_static(G23 / "subject01_static.trc", gait2392_trial())


@pytest.fixture(scope="session")
def datasets():
    return {
        "plugingait": (c3d_trial, None),
        "rajagopal": (rajagopal_trial, rajagopal_static),
        "gait2392": (gait2392_trial, gait2392_static),
    }
