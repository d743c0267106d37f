"""Shared test helpers: the three real datasets of ``../shared/data``, loaded with the package's
own loaders (``gc_ocp.io``). Masses come from the OpenSim scale set-ups (not in the files);
heights of the OpenSim subjects are not in the files either and are left to the kinematics'
estimate. Tests needing these data are skipped with a reason when ``../shared/data`` is absent."""

from __future__ import annotations

import functools
import json
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
def bundled_stances() -> tuple:
    """The bundled example trial's stances as the diagnosis takes them (``fit_data``'s), made
    once per test process (a tuple: a test that needs a list makes its own)."""
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import fit_data

    trial = load_trial()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # LLS start / height notes are tested elsewhere
        _, data, _ = fit_data([(trial, compute_kinematics(trial))])
    return tuple(data)


@pytest.fixture(scope="session")
def datasets():
    return {
        "plugingait": (c3d_trial, None),
        "rajagopal": (rajagopal_trial, rajagopal_static),
        "gait2392": (gait2392_trial, gait2392_static),
    }


PINS = Path(__file__).resolve().parent / "pins"
PIN_OBJECTIVE_RTOL = 1e-5
"""Ipopt stops when the objective changes by < 1e-6 (relative) over 5 iterations
(``IpoptOptions.acceptable_obj_change_tol``): a refit that takes another path to the same
minimum ends within a few such steps of it."""
PIN_RMS_ATOL = 0.01
"""[% BW or % BW x H]: the precision the reports print; RMS moves by ~1e-4 of itself at the
objective tolerance above, while a different local minimum moves it by tenths."""
PIN_COP_ATOL_MM = 0.1


def assert_matches_pins(name: str, report) -> None:
    """The fitted objective, RMS per channel and COP RMS of ``report`` equal the pinned ones
    (``tests/pins/fit_pins.json``) within the solver's tolerance."""
    import json

    pin = json.loads((PINS / "fit_pins.json").read_text())[name]
    parts = [(report.result, pin)]
    if "heldout" in pin:
        assert report.heldout_label == pin["heldout"]["label"]
        parts.append((report.heldout, pin["heldout"]))
    for res, p in parts:
        assert res.objective == pytest.approx(p["objective"], rel=PIN_OBJECTIVE_RTOL), name
        assert set(res.rms) == set(p["rms"]), name
        for side, chans in p["rms"].items():
            for ch, v in chans.items():
                assert res.rms[side][ch] == pytest.approx(v, abs=PIN_RMS_ATOL), (name, side, ch)
            assert res.cop_rms_mm[side] == pytest.approx(p["cop_rms_mm"][side], abs=PIN_COP_ATOL_MM)


def synthetic_stances(rng, marker_noise: float, per_foot: int = 3):
    """``(stances, truth)``: ``per_foot`` synthetic stances of each foot under
    :func:`~gc_ocp.estimation.synthetic.default_truth` (10 mm sink, 0.5 % BW force noise), the
    feet seen through ``marker_noise`` [m] of virtual-marker noise."""
    from gc_ocp.estimation.synthetic import default_truth, synthetic_stance

    truth = default_truth()
    sts = [
        synthetic_stance(
            side,
            truth,
            t0=1.1 * j,
            sink=0.010,
            rng=rng,
            marker_noise=marker_noise,
            force_noise=0.005 * 700,
            label=f"syn:{side}{j}",
        )
        for side in ("left", "right")
        for j in range(per_foot)
    ]
    return sts, truth


def strict_json(text: str):
    """``json.loads`` that refuses the words ``NaN``/``Infinity`` Python's own writer uses and
    strict JSON (JavaScript, jq, R's jsonlite) has not: what the package's documents must be."""

    def refuse(word):
        raise ValueError(f"not strict JSON: {word}")

    return json.loads(text, parse_constant=refuse)
