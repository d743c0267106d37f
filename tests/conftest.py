"""Test helpers: minimal private loaders of the three shared datasets (the package loaders are
written elsewhere). Markers in lab (Z up, X forward, Y left), metres; stances from
../shared/data/README.md."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from gc_ocp.trial import Plate, Stance, Trial

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"  # ../shared beside the repo
YUP_TO_LAB = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # (x, y, z) -> (x, -z, y)


def read_trc(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Labels, time (n,), markers (n, m, 3) in file axes [mm -> m]."""
    lines = Path(path).read_text().splitlines()
    header = dict(zip(lines[1].split(), lines[2].split(), strict=False))
    units, rate = header["Units"], float(header["DataRate"])
    names = [c.strip() for c in lines[3].split("\t")[2:] if c.strip()]
    rows = []
    for ln in lines[5:]:
        if not ln.strip():
            continue
        vals = ln.split("\t")
        row = [float(v) if v.strip() else np.nan for v in vals[: 2 + 3 * len(names)]]
        row += [np.nan] * (2 + 3 * len(names) - len(row))
        rows.append(row)
    a = np.array(rows)
    scale = 1e-3 if units == "mm" else 1.0
    t = (a[:, 0] - a[0, 0]) / rate  # the Time column is rounded to 1 ms in some files
    return names, t, a[:, 2:].reshape(len(a), len(names), 3) * scale


def _plate(name, height):
    z = np.zeros((2, 3))
    return Plate(name, np.array([0.0, 1.0]), z, z, np.zeros(3), "lab_origin", None, height)


def _stances(lst, surface):
    return tuple(Stance(side, i, a, b, np.array([0, 0, surface]), "lab_origin") for i, (side, a, b) in enumerate(lst))


def trc_trial(path, mass, stances, surface, height=None) -> Trial:
    names, t, m = read_trc(path)
    m = m @ YUP_TO_LAB.T
    plates = tuple(_plate(f"p{i}", surface) for i in range(len(stances)))
    return Trial(Path(path), names, m, t, plates, mass, height, _stances(stances, surface),
                 lab_rotation=YUP_TO_LAB)


@functools.cache
def c3d_trial() -> Trial:
    import ezc3d

    path = DATA / "plugingait_overground/test_small.c3d"
    c = ezc3d.c3d(str(path))
    p = c["parameters"]["POINT"]
    labels = p["LABELS"]["value"]
    n_real = labels.index("CentreOfMass")  # later labels are Vicon model outputs
    pts = c["data"]["points"][:3, :n_real, :].transpose(2, 1, 0) * 1e-3
    rate = float(p["RATE"]["value"][0])
    t = np.arange(pts.shape[0]) / rate
    st = [("right", 0.406, 1.065), ("left", 0.939, 1.616), ("right", 1.490, 2.139)]
    plates = tuple(_plate(f"plate{i}", 0.0) for i in range(3))
    return Trial(path, labels[:n_real], pts, t, plates, 63.6, 1.58, _stances(st, 0.0))


@functools.cache
def rajagopal_trial() -> Trial:
    st = [("right", 0.268, 1.023), ("left", 0.837, 1.589), ("right", 1.412, 2.167)]
    return trc_trial(DATA / "opensim_rajagopal_overground/motion_capture_walk.trc", 85.07, st, 0.0)


@functools.cache
def rajagopal_static() -> Trial:
    return trc_trial(DATA / "opensim_rajagopal_overground/static_walk_1.trc", 85.07, [], 0.0)


G2392_SURFACE = -0.0075  # treadmill surface: the COP of the MOT file lies at py = -7.5 mm


@functools.cache
def gait2392_trial() -> Trial:
    st = [("right", 0.618, 1.408), ("left", 1.247, 2.017)]
    return trc_trial(DATA / "opensim_gait2392_treadmill/subject01_walk1.trc", 72.6, st, G2392_SURFACE)


@functools.cache
def gait2392_static() -> Trial:
    return trc_trial(DATA / "opensim_gait2392_treadmill/subject01_static.trc", 72.6, [], G2392_SURFACE)


@pytest.fixture(scope="session")
def datasets():
    return {
        "plugingait": (c3d_trial, None),
        "rajagopal": (rajagopal_trial, rajagopal_static),
        "gait2392": (gait2392_trial, gait2392_static),
    }
