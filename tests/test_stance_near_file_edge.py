"""A stance near the start of the recording (issue 21, part 0, bug 2).

The clock-offset effect (``time_offset``) resamples the plate signal up to its bound (50 ms) plus
the reach of its interpolation kernel (steps of 2.5 ms) beyond a stance's frames. A recording that begins inside that
reach used to stop the whole diagnosis with an input error. Now the trial's bound shrinks to
what the plate signal allows (recorded in the result block, flagged), and a candidate that still
cannot be evaluated is reported as such while the others are ranked.

Real data: the bundled Plug-in Gait trial cut so that its first heel strike (right, 0.407 s)
comes 60 ms (or 20 ms) after the first sample of the file.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import warnings

import numpy as np
import pytest
from conftest import c3d_trial

from gc_ocp.errors import InputError
from gc_ocp.estimation.components import base_model, model_from_names
from gc_ocp.estimation.components.time_offset import TimeOffset, interpolation_weights
from gc_ocp.trial import Trial


def cut_start(trial: Trial, lead: float) -> Trial:
    """``trial`` without the samples (markers and plates) more than ``lead`` seconds before its
    first heel strike, and without the stances that start before the cut (none here)."""
    t0 = trial.stances[0].t_on - lead
    keep = trial.marker_time >= t0
    plates = tuple(
        dataclasses.replace(
            p, time=p.time[p.time >= t0], force=p.force[p.time >= t0], moment=p.moment[p.time >= t0]
        )
        for p in trial.plates
    )
    return dataclasses.replace(
        trial,
        markers=trial.markers[keep],
        marker_time=trial.marker_time[keep],
        plates=plates,
        stances=tuple(s for s in trial.stances if s.t_on > t0),
    )


def _pairs(lead: float):
    from gc_ocp.kinematics import compute_kinematics

    trial = cut_start(c3d_trial(), lead)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [(trial, compute_kinematics(trial))]


@pytest.fixture(scope="module")
def cut60():
    """The trial cut 60 ms before its first heel strike, and its stances as a fit cuts them."""
    from gc_ocp.workflow.fitting import fit_data

    pairs = _pairs(0.060)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, data, _ = fit_data(pairs)
    return pairs, data


def _room(st) -> float:
    """Plate signal [s] beyond the stance's frames on its shorter side."""
    return min(st.time[0] - st.plate_time[0], st.plate_time[-1] - st.time[-1])


def test_the_bound_is_the_largest_the_plate_signal_holds(cut60):
    """On the stance 60 ms after the file start the kernel at the reduced bound reads only plate
    samples (every grid point with a non-zero weight lies inside the plate signal), and half a
    step more would read before the first sample. Stances far from the file's ends keep the full
    50 ms (the bound of existing data is unchanged)."""
    _, data = cut60
    comp = TimeOffset()
    edge, *inner = data
    assert _room(edge) < 0.0575  # what the old check needed: 20 + 3 steps of 2.5 ms
    b = comp.stance_bound(edge)
    assert 0 < b < comp.bound
    n = round(b / comp.step)
    assert n * comp.step == b  # a whole number of steps
    assert n == math.floor(_room(edge) / comp.step + 1e-6) - (comp.lobes - 1)

    def reach(u: float) -> int:
        """Largest |j| of a grid point with a non-zero kernel weight at delta = u steps."""
        w = interpolation_weights(u, comp.half, comp.lobes)
        return int(np.abs(np.flatnonzero(w != 0.0) - comp.half).max())

    slack = 1e-6  # [s] the plate's sample times carry round-off
    inside = max(reach(u) for u in np.linspace(-n, n, 4 * n + 5))  # on and between grid points
    assert inside == n + comp.lobes - 1 and inside * comp.step <= _room(edge) + slack
    assert reach(-n - 0.5) * comp.step > _room(edge) + slack  # half a step more would not fit
    assert [comp.stance_bound(st) for st in inner] == [comp.bound] * len(inner)
    # the same at the end of a recording: plate samples up to 40 ms after the last frame
    last = inner[-1]
    keep = last.plate_time <= last.time[-1] + 0.040
    ends = dataclasses.replace(
        last, plate_time=last.plate_time[keep], plate_wrench=last.plate_wrench[keep]
    )
    n_end = math.floor(_room(ends) / comp.step + 1e-6) - (comp.lobes - 1)
    assert 0 < n_end * comp.step < comp.bound
    assert comp.stance_bound(ends) == n_end * comp.step
    assert comp.trial_bound(edge.trial, data) == (b, edge.label)
    assert comp.trial_bound(edge.trial, inner) == (comp.bound, None)


def test_fit_with_time_offset_near_the_file_start(cut60):
    """The fit runs (it used to raise); the trial's block records the reduced bound and the
    stance that limits it, the variable's bounds are that bound, the flag says so, and the
    estimate lies within it."""
    from gc_ocp.workflow.fitting import fit

    pairs, data = cut60
    edge = data[0]
    b = TimeOffset().stance_bound(edge)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = fit(pairs, model=model_from_names(["time_offset"], base=base_model()))
    block = rep.result.blocks["time_offset"][edge.trial]
    assert block["bound_ms"] == b * 1e3
    assert block["bound_limited_by"] == edge.label
    assert abs(block["ms"]) <= block["bound_ms"] * (1 + 1e-6)  # Ipopt's bound relaxation
    spec = next(s for s in rep.result.variables if s.key == ("time_offset", edge.trial))
    # stored in units of the prior sigma: b / sigma * sigma is b to round-off
    assert float(spec.ub[0] * spec.scale[0]) == pytest.approx(b, rel=1e-12)
    [flag] = [f for f in rep.result.flags if f["code"] == "time_offset_bound_reduced"]
    assert flag["what"] == edge.trial and f"+-{b * 1e3:g} ms" in flag["message"]
    assert edge.label in flag["message"]


def test_a_fixed_delay_beyond_a_stance_s_plate_signal_is_refused(cut60):
    """A held-out stance keeps its trial's fitted delay: if that delay reaches beyond the plate
    signal around it, the stance is refused with the numbers (not resampled from held edge
    values); within it, it is used."""
    from gc_ocp.estimation.problem import build_estimation

    _, data = cut60
    edge = data[0]
    b = TimeOffset().stance_bound(edge)
    law = base_model()[0]
    build_estimation([edge], (law, TimeOffset(fixed={edge.trial: -b})))
    with pytest.raises(InputError, match=rf"fixed at -{(b + 0.005) * 1e3:.1f} ms.*allows \+-"):
        build_estimation([edge], (law, TimeOffset(fixed={edge.trial: -(b + 0.005)})))


def test_diagnosis_evaluates_time_offset_with_the_reduced_bound(cut60):
    """The diagnosis that stopped after several candidates now evaluates time_offset on this
    trial: a ranked row with held-out figures, carrying the reduced-bound flag."""
    from gc_ocp.diagnosis import diagnose

    pairs, _ = cut60
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = diagnose(
            pairs,
            candidates=["time_offset"],
            max_effects=0,
            n_boot=100,
            workers=1,
            mismatch_draws=4,
        )
    [row] = d.ranking
    assert row.not_evaluable is None and "not_evaluable" not in row.to_json()
    assert row.heldout_rms_reduction_pct is not None and len(row.per_stance_reduction_pct) == 2
    assert "time_offset_bound_reduced" in row.flags


def test_a_candidate_that_cannot_be_evaluated_is_reported_and_the_others_go_on():
    """Cut 20 ms before the heel strike, the stance's frames (30 ms margin) reach the first
    plate sample: no bound remains, time_offset is not evaluable. On two worker processes the
    diagnosis ranks damping, reports time_offset last with the message (row, note, summary,
    JSON, report), and does not retry it."""
    from gc_ocp.diagnosis import diagnose
    from gc_ocp.diagnosis.report import report_html

    pairs = _pairs(0.020)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = diagnose(
            pairs, candidates=["time_offset", "damping"], n_boot=100, workers=2, mismatch_draws=4
        )
    first, last = d.rounds[0]
    assert first.effect == "damping" and first.heldout_rms_reduction_pct is not None
    assert last.effect == "time_offset" and not last.passes
    assert "time_offset cannot be estimated" in last.not_evaluable
    assert "test_small:right@0.407s" in last.not_evaluable
    assert last.heldout_rms_reduction_pct is None and last.insample_rms_reduction_pct is None
    # whether damping is named or not, time_offset is not retried: had damping been added, a
    # second round would only have time_offset left, so there is one round either way
    assert d.selected in ([], ["damping"]) and len(d.rounds) == 1
    assert any(n.startswith("time_offset is not evaluable") for n in d.notes)
    assert re.search(r"\n +time_offset +not evaluable on these data", d.summary())
    js = json.loads(json.dumps(d.to_json()))
    assert js["ranking"][-1]["not_evaluable"] == last.not_evaluable
    page = report_html(d)
    assert "not evaluable on these data: time_offset cannot be estimated" in page
