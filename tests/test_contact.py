"""Tests of gc_ocp.contact: laws, equivalent wrench, LLS, synthetic sets, Table writers, plots."""

from __future__ import annotations

import json
import os
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from matplotlib.figure import Figure

from gc_ocp.contact import laws
from gc_ocp.contact.channels import CHANNELS, SEED_BW, SEED_BWH, channel_rms_pct, k_rms_pct
from gc_ocp.contact.equivalent_wrench import LawParams, model_wrench, wrench_per_unit_stiffness
from gc_ocp.contact.laws import (
    DEFAULT_SMOOTHING,
    Smoothing,
    normal_forces,
    unit_force_function,
    unit_forces,
)
from gc_ocp.contact.lls import SEED_LAW, fit_stiffness_lls
from gc_ocp.contact.plots import plot_sole, plot_wrench_fit
from gc_ocp.contact.seed_study import (
    SEED_TABLE1,
    TABLE1_CASES,
    TABLE1_KEYS,
    reproduce_seed,
    table1_json,
    write_tables,
)
from gc_ocp.contact.synthetic import SYNTHETIC_CASES, draw_case, synthetic_stances
from gc_ocp.errors import InputError, RankError
from gc_ocp.foot import UNITS, TrialKinematics
from gc_ocp.stance import StanceData
from gc_ocp.synthetic_foot import rolling_foot
from gc_ocp.trial import Plate, Stance, Trial
from gc_ocp.wrench import transport_moment

EPS = np.finfo(float).eps
K0 = 11974.0


# --------------------------------------------------------------------------- helpers / fixtures


def reference_unit_force(p, v, k, n, c, mu, h, vb, smooth, sm=DEFAULT_SMOOTHING):
    """Plain NumPy reference of the laws, written independently from laws.py (test only)."""
    x, xdot = h - p[2], -v[2]
    d = 1 + c * xdot
    if smooth:
        xs = 0.5 * (x + np.sqrt(x * x + sm.eps_x**2))
        fn = k * xs**n * 0.5 * (d + np.sqrt(d * d + sm.eps_damping**2))
    else:
        fn = k * x**n * max(d, 0.0) if x > 0 else 0.0
    vs = np.array([v[0] - vb[0], v[1] - vb[1]])
    ft = -mu * fn * vs / np.sqrt(vs @ vs + sm.v_eps**2)
    return np.array([ft[0], ft[1], fn])


def random_contact_state(rng, size):
    """Positions within +-8 mm of the ground and velocities of a few cm/s (stance-like)."""
    p = np.column_stack(
        [rng.uniform(-0.2, 0.2, size), rng.uniform(-0.2, 0.2, size), rng.uniform(-8e-3, 8e-3, size)]
    )
    v = rng.normal(0, 0.03, (size, 3))
    return p, v


@pytest.fixture(scope="module")
def feet():
    return {
        "right": rolling_foot("right", t0=0.0, margin=0.0),
        "left": rolling_foot("left", t0=0.55, margin=0.0),
    }


def _stance(foot, label, t_on, t_off, ref):
    w = foot.window(t_on, t_off)
    return StanceData(foot.side, label, w, np.zeros((w.time.size, 6)), ref)


@pytest.fixture(scope="module")
def template(feet):
    return [
        _stance(feet["right"], "R1", 0.0, 0.65, [0.2, -0.1, -0.04]),
        _stance(feet["left"], "L1", 0.55, 1.2, [0.9, 0.1, -0.04]),
    ]


K_TRUE_EXP = {
    "right": np.array([40e3, 35e3, 30e3, 30e3, 20e3]),
    "left": np.array([38e3, 36e3, 28e3, 33e3, 22e3]),
}
PLATE_NOISE_N = 2.0


@pytest.fixture(scope="module")
def fake_trial(feet):
    """A Trial whose plates record the model wrench (k = K_TRUE_EXP) plus 2 N / 2 N·m noise."""
    plates, stances = [], []
    for i, (side, t0, ec) in enumerate(
        [("right", 0.0, [0.2, -0.1, -0.04]), ("left", 0.55, [0.9, 0.1, -0.04])]
    ):
        f = feet[side]
        t = f.time  # plate sampled at the kinematic frames: no interpolation error
        w = model_wrench(f.positions, f.velocities, K_TRUE_EXP[side], ec, SEED_LAW)
        w = w + np.random.default_rng(i).normal(0, PLATE_NOISE_N, w.shape)
        plates.append(
            Plate(f"plate{i + 1}", t, w[:, :3], w[:, 3:], np.array(ec), "electrical_center")
        )
        stances.append(Stance(side, i, t0, t0 + 0.65, np.array(ec), "electrical_center"))
    trial = Trial(
        Path("fake.c3d"),
        (),
        np.zeros((0, 0, 3)),
        np.zeros(0),
        tuple(plates),
        70.0,
        1.75,
        tuple(stances),
    )
    kin = TrialKinematics("fake", np.zeros(0), np.zeros((0, 1)), np.zeros(0), feet, 6.0)
    return trial, kin


# --------------------------------------------------------------------------- laws


@pytest.mark.parametrize("n", [1.0, 1.5, 3.0])
def test_zero_and_negative_penetration_give_exactly_zero_force(n):
    f = unit_force_function(smooth=False)
    p = ca.SX.sym("p", 3)
    jac = ca.Function(
        "J",
        [p],
        [
            ca.jacobian(
                f(
                    p,
                    [0.01, 0.02, -0.5],
                    K0,
                    n,
                    1.0,
                    0.8,
                    0.0,
                    [0.0, 0, 0],
                    *DEFAULT_SMOOTHING.as_tuple(),
                ),
                p,
            )
        ],
    )
    for z in (0.0, 1e-12, 1e-3, 0.5):  # p_z >= ground: x <= 0
        for vz in (-1.0, 0.0, 2.0):
            out = np.asarray(
                f(
                    [0.1, 0.2, z],
                    [0.3, -0.1, vz],
                    K0,
                    n,
                    1.0,
                    0.8,
                    0.0,
                    [0, 0, 0],
                    *DEFAULT_SMOOTHING.as_tuple(),
                )
            ).ravel()
            assert np.array_equal(out, np.zeros(3))  # exactly, not approximately
        assert np.array_equal(np.asarray(jac([0.1, 0.2, z])), np.zeros((3, 3)))
    # the vectorised path too
    pos = np.array([[[0, 0, 0.0], [0, 0, 0.004], [0, 0, 1.0]]])
    assert np.array_equal(unit_forces(pos, np.ones_like(pos), K0, n, 1.0, 0.8), np.zeros((1, 3, 3)))


def test_no_pulling_when_separating_fast():
    # xdot = -v_z; separating at 2 m/s with c = 1 s/m gives 1 + c*xdot = -1 < 0: clamp to 0.
    out = unit_forces(np.array([0, 0, -0.004]), np.array([0.0, 0, 2.0]), K0, 1.0, 1.0, 0.8)
    assert np.array_equal(out, np.zeros(3))
    # smooth variant: positive and below the smoothing bias k*x*eps_d^2/(4*|d|) * (1 + margin)
    out_s = unit_forces(
        np.array([0, 0, -0.004]), np.array([0.0, 0, 2.0]), K0, 1.0, 1.0, 0.0, smooth=True
    )
    xs = 0.5 * (0.004 + np.sqrt(0.004**2 + DEFAULT_SMOOTHING.eps_x**2))
    assert 0 < out_s[2] <= K0 * xs * DEFAULT_SMOOTHING.eps_damping**2 / 4 * 1.01


def test_smooth_variant_is_positive_and_converges_to_exact():
    sm = DEFAULT_SMOOTHING
    x = np.array([-5e-3, -1e-3, 0.0, 2e-3, 5e-3, 2e-2])
    fs = normal_forces(x, 0.0, K0, 1.0, 0.0, smooth=True)
    fe = normal_forces(x, 0.0, K0, 1.0, 0.0, smooth=False)
    assert np.all(fs > 0)
    assert fs[2] == pytest.approx(
        K0 * sm.eps_x / 2 * (0.5 * (1 + np.sqrt(1 + sm.eps_damping**2))), rel=1e-14
    )
    # x_s - x = (sqrt(x^2+eps^2) - x)/2 <= eps^2/(4x) for x > 0, plus the damping bias eps_d^2/4
    pos = x > 0
    bound = K0 * (sm.eps_x**2 / (4 * x[pos]) + x[pos] * sm.eps_damping**2 / 4) * 1.0001
    assert np.all(np.abs(fs[pos] - fe[pos]) <= bound)
    # x << -eps: x_s ~ eps^2/(4|x|)
    assert fs[0] <= K0 * sm.eps_x**2 / (4 * 5e-3) * 1.01


def test_no_point_gives_no_force():
    """``normal_forces`` of empty arrays is empty, as ``unit_forces``'s is (it mapped one
    placeholder point and could not reshape its force to the empty shape)."""
    assert normal_forces(np.zeros(0), 0.0, K0).shape == (0,)
    assert normal_forces(np.zeros((0, 5)), 0.0, K0, 1.5, 0.5, smooth=True).shape == (0, 5)
    assert unit_forces(np.zeros((0, 3)), np.zeros((0, 3)), K0).shape == (0, 3)
    assert normal_forces(0.002, 0.0, K0).shape == ()  # a scalar stays one


@pytest.mark.parametrize("smooth", [False, True])
def test_numeric_symbolic_and_reference_agree(smooth):
    rng = np.random.default_rng(1)
    p, v = random_contact_state(rng, 200)
    k = rng.uniform(5e3, 5e4, 200)
    n, c, mu, h, vb = 1.3, 0.7, 0.6, 0.001, np.array([-1.1, 0.05, 0.0])
    num = unit_forces(p, v, k, n, c, mu, h, vb, smooth=smooth)
    ref = np.array(
        [reference_unit_force(p[i], v[i], k[i], n, c, mu, h, vb, smooth) for i in range(200)]
    )
    # Same operations in a different order: agreement to a few ulps of the force scale.
    scale = np.abs(ref).max()
    np.testing.assert_allclose(num, ref, rtol=0, atol=1e3 * EPS * scale)
    f = unit_force_function(smooth)
    # SX: symbolic call, then numeric evaluation of the resulting expression graph.
    ps, vs = ca.SX.sym("p", 3), ca.SX.sym("v", 3)
    g = ca.Function(
        "g", [ps, vs], [f(ps, vs, k[0], n, c, mu, h, vb, *DEFAULT_SMOOTHING.as_tuple())]
    )
    # MX: the same Function embedded in an MX graph.
    pm, vm = ca.MX.sym("p", 3), ca.MX.sym("v", 3)
    gm = ca.Function(
        "gm", [pm, vm], [f(pm, vm, k[0], n, c, mu, h, vb, *DEFAULT_SMOOTHING.as_tuple())]
    )
    for i in range(20):
        a = np.asarray(g(p[i], v[i])).ravel()
        b = np.asarray(gm(p[i], v[i])).ravel()
        assert np.array_equal(a, b)
        k_i = k[i]
        a0 = np.asarray(f(p[i], v[i], k_i, n, c, mu, h, vb, *DEFAULT_SMOOTHING.as_tuple())).ravel()
        np.testing.assert_array_equal(a0, num[i])  # map(n) and a plain call: identical


def _stacked_function(smooth):
    """unit_force as a function of one vector z = (p, v, k, n, c, mu, h, vb) (14,)."""
    z = ca.SX.sym("z", 14)
    f = unit_force_function(smooth)(
        z[0:3], z[3:6], z[6], z[7], z[8], z[9], z[10], z[11:14], *DEFAULT_SMOOTHING.as_tuple()
    )
    return z, f


@pytest.mark.parametrize("smooth", [True, False])
def test_casadi_jacobian_matches_central_differences(smooth):
    """Directional derivatives J d vs (f(z + h d) - f(z - h d)) / 2h along random directions.

    Error of the central difference: truncation h^2/6 * max|g'''| (g(t) = f(z + t d)) plus
    round-off ~ 2 * eps * max|f| / h. We take g''' from CasADi itself (exact third derivative
    along d at z), allow a factor 10 for its variation on [-h, h], and choose h = 1e-7 on
    direction components scaled like the inputs (mm, cm/s, 10^4 N/m...).
    """
    z, f = _stacked_function(smooth)
    t = ca.SX.sym("t")
    d_sym = ca.SX.sym("d", 14)
    g = ca.substitute(f, z, z + t * d_sym)
    g1 = ca.jacobian(g, t)
    g3 = ca.jacobian(ca.jacobian(g1, t), t)
    G = ca.Function("G", [z, d_sym, t], [g, g1, g3])
    rng = np.random.default_rng(2)
    scale = np.r_[[1e-3] * 3, [1e-2] * 3, 1e3, 0.1, 0.1, 0.1, 1e-3, [0.1] * 3]
    h = 1e-7
    checked = 0
    for _ in range(200):
        p, v = random_contact_state(rng, 1)
        z0 = np.r_[
            p[0],
            v[0],
            rng.uniform(5e3, 5e4),
            rng.uniform(1, 2),
            rng.uniform(0, 1),
            rng.uniform(0.3, 1),
            0.0,
            rng.normal(0, 0.5, 3),
        ]
        if not smooth:  # stay away from the kinks x = 0 and 1 + c*xdot = 0
            x = -z0[2]
            if abs(x) < 1e-4 or 1 + z0[8] * (-z0[5]) < 1e-2:
                continue
        d = rng.normal(size=14) * scale
        _, jd, g3v = (np.asarray(a).ravel() for a in G(z0, d, 0.0))
        fp = np.asarray(G(z0, d, h)[0]).ravel()
        fm = np.asarray(G(z0, d, -h)[0]).ravel()
        fd = (fp - fm) / (2 * h)
        fmax = np.max(np.abs(np.r_[fp, fm])) + 1.0
        tol = 10 * (h**2 / 6 * np.abs(g3v) + 2 * EPS * fmax / h) + 1e-12
        assert np.all(np.abs(fd - jd) <= tol), (z0, fd, jd, tol)
        checked += 1
    assert checked > 100


def test_friction_opposes_sliding_is_bounded_and_respects_belt():
    rng = np.random.default_rng(3)
    p, v = random_contact_state(rng, 500)
    p[:, 2] = -np.abs(p[:, 2]) - 1e-4  # all in contact
    mu, vb = 0.7, np.array([-1.2, 0.0, 0.0])
    F = unit_forces(p, v, K0, 1.0, 0.0, mu, 0.0, vb)
    vs = (v - vb)[:, :2]
    ft, fn = F[:, :2], F[:, 2]
    assert np.all(fn > 0)
    assert np.all(np.einsum("ij,ij->i", ft, vs) < 0)  # opposite the sliding
    # anti-parallel: the 2-D cross product vanishes up to round-off
    np.testing.assert_allclose(
        ft[:, 0] * vs[:, 1] - ft[:, 1] * vs[:, 0],
        0,
        atol=1e3 * EPS * (np.abs(ft).max() * np.abs(vs).max()),
    )
    mag = np.linalg.norm(ft, axis=1)
    assert np.all(mag < mu * fn)
    speed = np.linalg.norm(vs, axis=1)
    np.testing.assert_allclose(
        mag, mu * fn * speed / np.hypot(speed, DEFAULT_SMOOTHING.v_eps), rtol=1e-13
    )
    # a foot moving with the belt does not slide: no friction; vertical velocity is not sliding
    F0 = unit_forces(
        np.array([0, 0, -0.003]), np.array([-1.2, 0.0, -0.02]), K0, 1.0, 0.0, mu, 0.0, vb
    )
    assert F0[0] == 0 and F0[1] == 0 and F0[2] > 0
    # standing still on a belt moving backwards: the foot slides forward relative to the belt
    F1 = unit_forces(np.array([0, 0, -0.003]), np.zeros(3), K0, 1.0, 0.0, mu, 0.0, vb)
    assert F1[0] < 0 and abs(F1[0]) == pytest.approx(mu * F1[2] * 1.2 / np.hypot(1.2, 0.05))


def test_smoothing_rejects_nonpositive_lengths():
    with pytest.raises(InputError, match="v_eps"):
        Smoothing(v_eps=0.0)


# --------------------------------------------------------------------------- wrench model


def test_model_wrench_sums_unit_forces_and_torques(feet):
    f = feet["right"]
    k = np.array([1e4, 2e4, 3e4, 4e4, 5e4])
    ref = np.array([0.2, -0.1, -0.04])
    W = model_wrench(f.positions, f.velocities, k, ref, SEED_LAW)
    F = unit_forces(f.positions, f.velocities, k[None, :], 1.0, 0.0, SEED_LAW.mu)
    ref_w = np.hstack([F.sum(1), np.cross(f.positions - ref, F).sum(1)])
    np.testing.assert_allclose(W, ref_w, rtol=0, atol=1e3 * EPS * np.abs(ref_w).max())
    # k enters linearly: regressor @ k reproduces the wrench
    R = wrench_per_unit_stiffness(f.positions, f.velocities, ref, SEED_LAW)
    np.testing.assert_allclose(R @ k, W, rtol=0, atol=1e3 * EPS * np.abs(W).max())


@pytest.mark.parametrize("law", [SEED_LAW, LawParams(n=1.5, c=0.8, mu=0.9, smooth=True)])
def test_moving_reference_point_transports_the_wrench(feet, law):
    f = feet["left"]
    k = np.array([1e4, 2e4, 3e4, 4e4, 5e4])
    a, b = np.array([0.9, 0.1, -0.04]), np.array([-3.0, 2.0, 0.5])
    Wa = model_wrench(f.positions, f.velocities, k, a, law)
    Wb = model_wrench(f.positions, f.velocities, k, b, law)
    np.testing.assert_array_equal(Wa[:, :3], Wb[:, :3])  # same forces, bit for bit
    moved = transport_moment(Wa[:, :3], Wa[:, 3:], a, b)
    # exact algebra; only round-off of |r| * |F| ~ 4 m * 1e3 N remains
    np.testing.assert_allclose(moved, Wb[:, 3:], rtol=0, atol=1e2 * EPS * 4 * np.abs(Wa).max())


def test_model_wrench_shape_errors():
    with pytest.raises(InputError, match="but got"):
        model_wrench(np.zeros((3, 5)), np.zeros((3, 5)), np.ones(5), np.zeros(3))
    with pytest.raises(InputError, match="one value per unit"):
        model_wrench(np.zeros((3, 5, 3)), np.zeros((3, 5, 3)), np.ones(4), np.zeros(3))


# --------------------------------------------------------------------------- LLS


@pytest.mark.parametrize("case", SYNTHETIC_CASES[:2])
def test_lls_recovers_k_and_wrench_on_noiseless_data(case, template, feet):
    k_true, offsets = draw_case(case, np.random.default_rng(5), ("left", "right"))
    assert offsets is None
    data = synthetic_stances(template, feet, k_true, None, SEED_LAW)
    fit = fit_stiffness_lls(data, SEED_BW, SEED_BWH, SEED_LAW)
    kt = np.array([k_true[s][UNITS.index(u)] for s, u in fit.unknowns])
    # Requirement: < 1e-8 %. The fit is exact in exact arithmetic; with a condition number ~10
    # round-off gives ~1e-13 % (the seed reports 2e-13 %).
    assert fit.rank == 10
    assert k_rms_pct(fit.k_vector, kt) < 1e-8
    assert all(v < 1e-8 for v in fit.rms_pct.values())
    assert list(fit.rms_pct) == list(CHANNELS)


def test_lls_rejects_a_unit_never_in_contact(template):
    st = template[0]
    pts = st.foot.points_local.copy()
    pts[UNITS.index("TT"), 2] += 0.2  # toe tip 20 cm above the sole: never in contact
    lifted = st.with_foot(st.foot.with_points(pts)).with_measured(np.ones_like(st.measured))
    with pytest.raises(RankError, match=r"right/TT.*never in contact"):
        fit_stiffness_lls(
            [lifted, template[1].with_measured(np.ones((len(template[1].time), 6)))],
            SEED_BW,
            SEED_BWH,
        )


def test_lls_rejects_inseparable_units(template):
    st = template[0]
    pts = st.foot.points_local.copy()
    pts[1] = pts[0]  # PM on top of PL: identical regressor columns
    twin = st.with_foot(st.foot.with_points(pts)).with_measured(np.ones_like(st.measured))
    with pytest.raises(RankError, match=r"rank 4 < 5.*right/P[LM].*right/P[LM]"):
        fit_stiffness_lls([twin], SEED_BW, SEED_BWH)


def test_noisy_synthetic_is_reproducible_and_differs_from_nominal(template, feet):
    draws = [draw_case("synthetic_noisy_random_k", np.random.default_rng(7)) for _ in range(2)]
    for s in ("left", "right"):
        np.testing.assert_array_equal(draws[0][0][s], draws[1][0][s])
        np.testing.assert_array_equal(draws[0][1][s], draws[1][1][s])
        assert np.all(np.abs(draws[0][1][s]) <= 1e-3)
        assert np.all(np.abs(draws[0][0][s] / K0 - 1) <= 0.5)
    k_true, off = draws[0]
    noisy = synthetic_stances(template, feet, k_true, off)
    clean = synthetic_stances(template, feet, k_true, None)
    assert not np.allclose(noisy[0].measured, clean[0].measured)
    np.testing.assert_array_equal(noisy[0].positions, clean[0].positions)  # fitter sees nominal


# --------------------------------------------------------------------------- seed study


def test_reproduce_seed_tables(fake_trial, tmp_path):
    trial, kin = fake_trial
    calls = []
    res = reproduce_seed(
        trial, kin, seeds=3, out_dir=tmp_path, progress=lambda d, n, label: calls.append((d, n))
    )
    rows = res["table1"]
    assert [r["case"] for r in rows] == list(TABLE1_CASES)
    for r in rows:
        assert list(r)[: len(TABLE1_KEYS)] == list(TABLE1_KEYS)
        extra = list(r)[len(TABLE1_KEYS) :]
        if "noisy" in r["case"]:
            assert extra == [k + "_sd" for k in TABLE1_KEYS[1:]]
        else:
            assert extra == []
    assert rows[-1]["k_rms_pct"] is None
    for r in rows[:2]:
        assert all(r[k] < 1e-8 for k in TABLE1_KEYS[1:])
    assert calls[-1] == (2 + 2 * 3 + 1, 2 + 2 * 3 + 1)
    # experimental: plates = model with known k + 2 N noise -> k recovered within a few percent
    for side in ("left", "right"):
        got = np.array([res["table2"][side][u] for u in UNITS])
        np.testing.assert_allclose(got, K_TRUE_EXP[side], rtol=0.05)
    # written files: exact keys/order, seed values side by side
    # one set, with its owner record (gc_ocp.outputs.OWNER: no other command mixes files in)
    assert sorted(os.listdir(tmp_path)) == [
        ".gc_ocp_outputs",
        "table1.json",
        "table1.md",
        "table2.json",
        "table2.md",
    ]
    assert (tmp_path / ".gc_ocp_outputs").read_text() == "gc-ocp reproduce-seed\n"
    assert json.loads((tmp_path / "table1.json").read_text()) == json.loads(json.dumps(rows))
    assert [list(r) for r in json.loads((tmp_path / "table1.json").read_text())] == [
        list(r) for r in rows
    ]
    assert list(json.loads((tmp_path / "table2.json").read_text())) == ["left", "right"]
    md = (tmp_path / "table1.md").read_text()
    assert "20.3" in md and "2.31e-13" in md  # seed's experimental superior force, noiseless k
    assert (
        "-6.79e+04" in (tmp_path / "table2.md").read_text()
        or "-67927.68" in (tmp_path / "table2.md").read_text()
    )
    assert SEED_TABLE1["experimental"]["superior_force_pct_bw"] == 20.26


def test_table_writers_are_atomic(fake_trial, tmp_path, monkeypatch):
    trial, kin = fake_trial
    res = reproduce_seed(trial, kin, seeds=2)
    write_tables(res, tmp_path)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def boom(src, dst):
        raise OSError("disk full")

    changed = dict(res, table2={"left": {u: 1.0 for u in UNITS}, "right": {u: 2.0 for u in UNITS}})
    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        write_tables(changed, tmp_path)
    monkeypatch.undo()
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert after == before  # old files intact, no temporary file left behind
    # a malformed table is rejected before anything is written
    bad = dict(res, table1=[dict(r) for r in res["table1"]])
    bad["table1"][0].pop("lateral_force_pct_bw")
    with pytest.raises(InputError, match="must have keys"):
        write_tables(bad, tmp_path / "new")
    assert not (tmp_path / "new").exists()
    with pytest.raises(InputError, match="cases"):
        table1_json(res["table1"][::-1])


def test_channel_rms_normalisation():
    m = np.zeros((4, 6))
    s = np.zeros((4, 6))
    s[:, 2] = 68.9  # 10 % BW on the vertical force
    s[:, 4] = 117.3  # 10 % BW*H about lab y: mediolateral torque
    rms = channel_rms_pct(m, s, SEED_BW, SEED_BWH)
    assert rms["superior_force"] == pytest.approx(10.0)
    assert rms["mediolateral_torque"] == pytest.approx(10.0)
    assert rms["lateral_force"] == 0 and rms["longitudinal_torque"] == 0


# --------------------------------------------------------------------------- plots


def test_plots_return_figures(template, feet):
    data = synthetic_stances(template, feet, {s: np.full(5, K0) for s in ("left", "right")})
    fig = plot_wrench_fit(
        [d.time for d in data],
        [d.measured for d in data],
        [d.measured * 1.01 for d in data],
        sides=[d.side for d in data],
    )
    assert isinstance(fig, Figure) and len(fig.axes) == 12
    fig2 = plot_sole(
        {s: feet[s].points_local for s in ("left", "right")},
        k={"left": dict.fromkeys(UNITS, K0), "right": dict.fromkeys(UNITS, -K0)},
    )
    assert isinstance(fig2, Figure) and len(fig2.axes) == 2
    assert laws.unit_force_function(False).n_in() == len(laws.UNIT_FORCE_INPUTS)


def test_wrench_fit_figure_in_percent_body_weight_with_its_legend_off_the_curves(template, feet):
    """With ``normalisers`` the channels are drawn in % BW and % BW x H (the unit of every RMS
    the package prints; they were drawn in N beside tables in % BW), labelled so, and the
    legend sits below the axes: inside, it covered a second stance's curve."""
    data = synthetic_stances(template, feet, {s: np.full(5, K0) for s in ("left", "right")})
    norm = [(SEED_BW, SEED_BWH)] * len(data)
    fig = plot_wrench_fit(
        [d.time for d in data],
        [d.measured for d in data],
        [d.measured * 1.01 for d in data],
        sides=[d.side for d in data],
        normalisers=norm,
    )
    rows = {ax.get_ylabel().split("\n")[0]: ax for ax in fig.axes[::2]}  # first column
    sup = rows["superior force"]
    assert sup.get_ylabel().endswith("[% BW]")
    assert rows["mediolateral torque"].get_ylabel().endswith("[% BW×H]")
    # the first column's first line is the first stance's measured vertical force
    np.testing.assert_allclose(sup.lines[0].get_ydata(), 100 * data[0].measured[:, 2] / SEED_BW)
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:  # anchored below its axes: its top under the axes' bottom
            assert legend.get_bbox_to_anchor().y1 < ax.get_window_extent().y0
    assert sum(ax.get_legend() is not None for ax in fig.axes) == 2  # one per column
    with pytest.raises(InputError, match="one \\(BW, BW x H\\) per stance"):
        plot_wrench_fit(
            [d.time for d in data],
            [d.measured for d in data],
            [d.measured for d in data],
            normalisers=norm[:1],
        )


def test_frames_with_missing_plate_data_are_dropped(fake_trial):
    from gc_ocp.contact.lls import stances_from_trial

    trial, kin = fake_trial
    p0 = trial.plates[0]
    force = p0.force.copy()
    force[10:15] = np.nan  # a 5-sample gap in the plate record
    gappy = Plate(p0.name, p0.time, force, p0.moment, p0.reference_point, p0.reference_kind)
    trial2 = Trial(
        trial.source,
        (),
        trial.markers,
        trial.marker_time,
        (gappy, trial.plates[1]),
        trial.mass,
        trial.height,
        trial.stances,
    )
    full = stances_from_trial(trial, kin)
    cut = stances_from_trial(trial2, kin)
    assert len(cut[0].time) == len(full[0].time) - 5
    assert np.isfinite(cut[0].measured).all()
    res = reproduce_seed(trial2, kin, seeds=2)  # synthetic sets follow the kept frames
    assert res["table1"][0]["k_rms_pct"] < 1e-8


def test_reproduce_seed_without_height_uses_the_kinematics_height(fake_trial):
    """A trial without a height (an OpenSim TRC) is scaled by the kinematics with the height they
    estimate; the experimental row's BW*H uses that same height (as ``fit`` does and as
    docs/seed_study.md says), not the seed's 1,173 / 689 = 1.70 m. Exact: the height is a
    number passed through, the tolerance only allows float rounding of BW * H."""
    import dataclasses

    trial, kin = fake_trial
    no_height = dataclasses.replace(trial, height=None)
    kin_h = dataclasses.replace(kin, info={"height": 1.9})
    res = reproduce_seed(no_height, kin_h, seeds=1)
    assert res["settings"]["height_m"] == pytest.approx(1.9, rel=1e-12)
    fit = res["experimental_fit"]
    assert fit.bw_height == pytest.approx(no_height.body_weight * 1.9, rel=1e-12)
    assert any("kinematics' estimate" in n for n in res["notes"])
    # torques scale as 1 / H: the same fit with the trial's height given is the same numbers
    given = reproduce_seed(dataclasses.replace(trial, height=1.9), kin, seeds=1)
    exp, exp_given = res["table1"][-1], given["table1"][-1]
    for key in TABLE1_KEYS[1:]:
        assert exp[key] == exp_given[key] or exp[key] is None
    # no height anywhere: the seed's BW*H / BW, with a note
    bare = reproduce_seed(no_height, kin, seeds=1)
    assert bare["settings"]["height_m"] == pytest.approx(SEED_BWH / SEED_BW, rel=1e-12)
