"""No held-out frame reaches the start or the fit of ``fit(..., holdout=...)``.

The held-out stance's plate signal in the trial is changed by 25 % (a larger change fails the mass-vs-plates check): if any
of its frames reached the stiffness start (the seed's LLS) or the solve, the training fit would
move. It must stay identical to the bit, while the held-out evaluation (which does see the
stance) must change, proving the change reached the data the fit is given.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gc_ocp
from gc_ocp.antialias import band_limited, sample_rate
from gc_ocp.stance import _other_loads
from gc_ocp.workflow import fitting as fit_module

HOLDOUT = "right@0.407"
STRATEGY = ((1.0,),)  # one start: the test is about what the fit sees, not which start wins


@pytest.fixture(scope="module")
def bundled():
    trial = gc_ocp.load_trial()
    return trial, gc_ocp.compute_kinematics(trial)


def _spoiled(trial, label_part: str, factor: float = 1.25):
    """``trial`` with the plate signal of the stance whose label contains ``label_part``
    multiplied by ``factor`` over the stance and every margin a fit or a clock-offset model could
    read (0.1 s each side): whatever path reads the trial's plates sees the change."""
    st = next(s for s in trial.stances if label_part in s.label)
    others = [s for s in trial.stances if s is not st and s.plate == st.plate]
    assert all(o.t_off < st.t_on - 0.2 or o.t_on > st.t_off + 0.2 for o in others)
    plate = trial.plates[st.plate]
    w = ((plate.time >= st.t_on - 0.1) & (plate.time <= st.t_off + 0.1))[:, None]
    spoiled = dataclasses.replace(
        plate,
        force=np.where(w, factor * plate.force, plate.force),
        moment=np.where(w, factor * plate.moment, plate.moment),
    )
    plates = tuple(spoiled if i == st.plate else p for i, p in enumerate(trial.plates))
    return dataclasses.replace(trial, plates=plates)


def test_no_heldout_frame_reaches_the_start_or_the_fit(bundled, monkeypatch):
    model = gc_ocp.seed_model()
    seen: list[list[str]] = []
    real_lls = fit_module.with_lls_start

    def spy(model_, stances):
        seen.append([s.label for s in stances])
        return real_lls(model_, stances)

    monkeypatch.setattr(fit_module, "with_lls_start", spy)
    clean = fit_module.fit([bundled], model=model, holdout=HOLDOUT, strategies=STRATEGY)
    assert seen and all(not any(HOLDOUT in s for s in labels) for labels in seen)

    trial, kin = bundled
    spoiled = fit_module.fit(
        [(_spoiled(trial, HOLDOUT), kin)], model=model, holdout=HOLDOUT, strategies=STRATEGY
    )
    # identical to the bit: the same arithmetic on the same training frames
    np.testing.assert_array_equal(spoiled.result.x, clean.result.x)
    assert spoiled.result.objective == clean.result.objective
    # the spoiled stance did reach the held-out evaluation (the test can fail)
    fc, fs = clean.heldout.stance_fits[0], spoiled.heldout.stance_fits[0]
    # scaled by 1.25, the margins' quiet samples of 16-20 N pass the 20 N a margin may read
    # (gc_ocp.stance.quiet_margins), so the spoiled stance's margins may end sooner: the frames
    # it keeps are the clean stance's, with its measurement scaled, except where the
    # anti-alias low-pass (gc_ocp.antialias) reaches the samples its margins now zero
    assert (
        np.isin(fs["time"], fc["time"]).all() and fs["in_contact"].sum() == fc["in_contact"].sum()
    )
    # the filter is linear: the spoiled reading is 1.25 x the clean one less the filtered
    # samples its margins zero and the clean ones keep (zero but for the filter's smear)
    st = next(s for s in trial.stances if HOLDOUT in s.label)
    t = trial.plates[st.plate].time
    clean_to, clean_from = _other_loads(trial, st)
    spoiled_to, spoiled_from = _other_loads(_spoiled(trial, HOLDOUT), st)
    cut = ((t > clean_to) & (t <= spoiled_to)) | ((t >= spoiled_from) & (t < clean_from))
    assert cut.any()  # the margins did move (else the comparison below is 1.25 x exactly)
    lost = band_limited(t, cut[:, None] * trial.stance_wrench(st, t), sample_rate(kin.time))
    lost = np.column_stack([np.interp(fs["time"], t, c) for c in lost.T])
    same = np.isin(fc["time"], fs["time"])
    # rounding of sums over the filter's ~400 taps: 1e-9 of a body weight
    np.testing.assert_allclose(
        fs["measured"], 1.25 * (fc["measured"][same] - lost), atol=1e-9 * trial.body_weight
    )
    assert np.abs(fs["measured"] - fc["measured"][same]).max() > 0.1 * trial.body_weight


def test_a_training_frame_does_reach_the_fit(bundled):
    """The converse, so that the test above can fail: spoiling a *training* stance moves the
    fit."""
    model = gc_ocp.seed_model()
    clean = fit_module.fit([bundled], model=model, holdout=HOLDOUT, strategies=STRATEGY)
    trial, kin = bundled
    other = next(s.label for s in trial.stances if HOLDOUT not in s.label)
    spoiled = fit_module.fit(
        [(_spoiled(trial, other), kin)], model=model, holdout=HOLDOUT, strategies=STRATEGY
    )
    assert not np.array_equal(spoiled.result.x, clean.result.x)
