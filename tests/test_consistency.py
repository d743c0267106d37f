"""Checks before fitting: damaged copies of real trials end in a clear error or an excluded
stance with its reason, never in a silent fit (issue "no silent wrong answer")."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import c3d_trial, gait2392_trial, rajagopal_trial

from gc_ocp.errors import InputError, PlateError
from gc_ocp.io.consistency import check_for_fit
from gc_ocp.trial import Plate


@pytest.fixture(scope="module")
def walk():
    from gc_ocp.kinematics import compute_kinematics

    t = c3d_trial()
    return t, compute_kinematics(t)


def test_clean_trials_pass_unchanged():
    from gc_ocp.kinematics import compute_kinematics

    for f in (c3d_trial, rajagopal_trial):
        t = f()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            k = compute_kinematics(t)
        (t2, _), notes = check_for_fit([(t, k)])[0][0], check_for_fit([(t, k)])[1]
        assert t2.stances == t.stances and notes == []


def _motion_of_another_moment(kin, dt):
    feet = {s: dataclasses.replace(f, time=f.time - dt) for s, f in kin.feet.items()}
    return dataclasses.replace(kin, feet=feet)


def test_forces_of_another_motion_are_refused(walk):
    """The motion taken 0.4 s later than the forces (markers that do not belong to these plate
    data): in no stance is the centre of pressure under the foot."""
    t, k = walk
    with pytest.raises(PlateError, match="do not belong"):
        check_for_fit([(t, _motion_of_another_moment(k, 0.4))])


@pytest.mark.parametrize("mass", [45.0, 90.0])
def test_wrong_mass_is_refused(walk, mass):
    t, k = walk
    with pytest.raises(
        InputError, match=r"check the mass \(--mass KG, mass=...; the plates suggest 6\d\.\d kg\)"
    ):
        check_for_fit([(dataclasses.replace(t, mass=mass), k)])


def test_a_mass_estimated_from_plates_in_the_wrong_unit_is_refused(walk):
    """No mass recorded and plates in lbf read as newtons: the mass estimated from them is the
    subject's divided by 4.45 (14.3 kg here for a subject of 1.62 m), which no person has
    (body-mass index 5.4); refused, naming the forces' unit. The right estimate passes."""
    from gc_ocp.errors import MassError
    from gc_ocp.trial import ESTIMATED

    t, k = walk
    est = f"{ESTIMATED} from the force data"
    ok = dataclasses.replace(t, mass_source=est, height=1.62)
    check_for_fit([(ok, k)])
    low = dataclasses.replace(ok, mass=t.mass / 4.4482216152605)
    with pytest.raises(MassError, match=r"body-mass index of 5\.\d.*not in newtons"):
        check_for_fit([(low, k)])


def test_kinematics_of_another_trial_are_refused(walk):
    """A notebook's slip, the kinematics of another trial beside a trial (another name, or the
    same file's motion cut shorter): refused naming both (it was fitted: the feet of one walk
    under the plates of another, the flags blaming the contact model)."""
    t, k = walk
    other = dataclasses.replace(k, trial_name="Walking2")
    with pytest.raises(InputError, match="are of 'Walking2'.*pair each trial with its own"):
        check_for_fit([(t, other)])
    shorter = dataclasses.replace(k, time=k.time[:-10])
    with pytest.raises(InputError, match="not of that trial"):
        check_for_fit([(t, shorter)])


def test_belt_speed_on_overground_is_refused(walk):
    t, k = walk
    with pytest.raises(InputError, match="overground walking; drop --belt-speed"):
        check_for_fit([(dataclasses.replace(t, belt_velocity=np.array([-1.1, 0.0, 0.0])), k)])


def test_treadmill_without_belt_speed_uses_the_estimate():
    from gc_ocp.kinematics import compute_kinematics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = gait2392_trial()
        k = compute_kinematics(t)
    (t2, _), notes = check_for_fit([(t, k)])[0][0], check_for_fit([(t, k)])[1]
    assert -t2.belt_velocity[0] == pytest.approx(1.056, abs=0.01)
    assert any("treadmill" in n for n in notes)


def test_same_trial_twice_is_refused(walk):
    with pytest.raises(InputError, match="given twice"):
        check_for_fit([walk, walk])


def test_unzeroed_plate_is_reported(walk):
    t, k = walk
    p0 = t.plates[0]
    drift = np.linspace(0.0, 60.0, p0.time.size)  # 0 -> 60 N over the trial
    plates = (
        dataclasses.replace(p0, force=p0.force + np.c_[0 * drift, 0 * drift, drift]),
        *t.plates[1:],
    )
    assert isinstance(plates[0], Plate)
    _, notes = check_for_fit([(dataclasses.replace(t, plates=plates), k)])
    assert any("while unloaded" in n and p0.name in n for n in notes)


def _with_missing_plate_samples(t, n=40, offset=0.0):
    """``t`` with its plates' first ``n`` samples missing (NaN, as a MOT's blank cells load) and
    ``offset`` [N] added to their vertical force."""
    plates = []
    for p in t.plates:
        f, m = p.force + np.array([0.0, 0.0, offset]), p.moment.copy()
        f[:n], m[:n] = np.nan, np.nan
        plates.append(dataclasses.replace(p, force=f, moment=m))
    return dataclasses.replace(t, plates=tuple(plates))


def test_missing_plate_samples_leave_the_body_weight_and_drift_checks():
    """20 ms of missing plate samples at the start of a MOT: the stride-long windows without
    them still check the mass (before, the NaN ran through the cumulative sum into every window,
    the check read NaN and a mass 76 % off passed silently), and the unloaded samples left still
    show an unzeroed plate (before, the median of a slice holding a NaN was NaN: no note)."""
    from gc_ocp.errors import MassError
    from gc_ocp.io.checks import stride_body_weight
    from gc_ocp.io.consistency import body_weight, plate_drift

    t = _with_missing_plate_samples(rajagopal_trial())
    value, t0, t1 = stride_body_weight(t)
    assert value == pytest.approx(t.body_weight, rel=0.05) and t0 >= t.plates[0].time[40]
    with pytest.raises(MassError, match="check the mass"):
        body_weight(dataclasses.replace(t, mass=150.0))
    notes = plate_drift(_with_missing_plate_samples(rajagopal_trial(), offset=30.0))
    assert [p.name for p in t.plates] == [
        p.name for p in t.plates if any(f"plate {p.name} reads 30 N" in n for n in notes)
    ]


def test_stance_partly_off_its_plate_is_excluded(walk):
    """The plate of the first stance moved forward (its corners, not its forces) so that its rear
    edge lies 135 mm in front of the heel at loading response: the heel stands off the plate;
    the stance is excluded with the reason, the others are kept."""
    t, k = walk
    s0 = t.stances[0]
    p = t.plates[s0.plate]
    foot = k.feet[s0.side]
    i = np.searchsorted(foot.time, s0.t_on + 0.1 * s0.duration)
    heel_x = foot.positions[i, :, 0].min()
    shift = heel_x - np.asarray(p.corners)[:, 0].min() + 0.135
    moved = dataclasses.replace(p, corners=np.asarray(p.corners) + np.array([shift, 0.0, 0.0]))
    plates = tuple(moved if i == s0.plate else q for i, q in enumerate(t.plates))
    [(t2, _)], notes = check_for_fit([(dataclasses.replace(t, plates=plates), k)])
    assert any("off plate" in n for n in notes)
    kept = {s.label for s in t2.stances}
    assert s0.label not in kept and len(kept) == len(t.stances) - 1
    assert any("off plate" in e.reason for e in t2.excluded_stances)


def _as(t, name, **kw):
    return dataclasses.replace(t, source=t.source.with_name(name), **kw)


def test_trials_of_two_people_are_refused_naming_each_file_and_value():
    """Recorded masses 16 % apart (63.6 and 74 kg, the bundled trial and PiG_Motion3's) or
    heights 18 cm apart are two people; 2 % and 1 cm are one person's sessions."""
    from gc_ocp.io.consistency import one_subject

    t = c3d_trial()  # 63.6 kg, 1.58 m, both from the file
    with pytest.raises(InputError, match="not of one subject: their recorded masses") as e:
        one_subject([t, _as(t, "other.c3d", mass=74.0)])
    assert str(t.source) in str(e.value) and "other.c3d: 74 kg" in str(e.value)
    assert "--mass" in str(e.value)
    with pytest.raises(InputError, match="recorded heights differ"):
        one_subject([t, _as(t, "other.c3d", height=1.76)])
    same, notes = one_subject([t, _as(t, "b.c3d", mass=t.mass * 1.02, height=t.height + 0.01)])
    assert [x.mass for x in same] == [t.mass, t.mass * 1.02] and notes == []


def test_masses_estimated_per_trial_become_one_for_the_subject():
    from gc_ocp.io.consistency import one_subject

    t = c3d_trial()
    est = [
        _as(t, f"w{i}.c3d", mass=m, mass_source=f"ESTIMATE {m:.1f} kg from the force data (...)")
        for i, m in enumerate((83.5, 84.5, 86.0))
    ]
    pooled, [note] = one_subject(est)
    assert [x.mass for x in pooled] == [pytest.approx(84.667, abs=1e-3)] * 3
    assert pooled[0].mass_source.startswith("ESTIMATE 84.7 kg: the mean")
    assert "83.5, 84.5, 86.0" in note
    again, notes = one_subject(pooled)  # the fit pools what the loader pooled: nothing changes
    assert all(a is b for a, b in zip(again, pooled, strict=True)) and notes == []
    # estimates 20 % apart: pooled, but the fit's notes say the plates disagree or two people
    apart = [dataclasses.replace(e, mass=m) for e, m in zip(est[:2], (75.0, 90.0), strict=True)]
    _, notes = one_subject(apart)
    assert any("mass estimates differ by 20 %" in n and "--mass" in n for n in notes)
    # 50 % apart (beyond two estimates each within 15 % of one mass): two people or a plate
    far = [dataclasses.replace(e, mass=m) for e, m in zip(est[:2], (60.0, 90.0), strict=True)]
    with pytest.raises(InputError, match="masses 50 % apart.*w0.c3d: 60.0 kg"):
        one_subject(far)
    # an estimate 31 % above another trial's recorded mass (the BTS subject's plates, 83.5 kg,
    # against the bundled trial's 63.6 kg) is not that subject's trial either
    with pytest.raises(InputError, match=r"plates of .*w0.c3d give 83.5 kg \(\+31%"):
        one_subject([t, est[0]])
    # a trial with a recorded mass gives it to the others (their estimates are not averaged in)
    near = [dataclasses.replace(e, mass=t.mass * f) for e, f in ((est[0], 1.05), (est[2], 0.9))]
    mixed, _ = one_subject([near[0], t, near[1]])
    assert [x.mass for x in mixed] == [t.mass] * 3
    assert str(t.source) in mixed[0].mass_source


def test_heights_the_package_estimated_are_not_two_people():
    """Heights estimated from each trial's markers (a few cm apart between trials of one
    person) are not compared as recorded ones but become one height for the subject, so that
    every stance is in the same % BW x height; the same rule (``Trial.height_estimated``) tells
    the fit's own estimate and the loader's from a file's."""
    from gc_ocp.io.consistency import one_subject
    from gc_ocp.trial import ESTIMATED

    t = c3d_trial()
    assert not t.mass_estimated and not t.height_estimated  # both in the C3D's parameters
    est = [
        _as(t, f"w{i}.c3d", height=h, height_source=f"{ESTIMATED} from the markers")
        for i, h in enumerate((1.70, 1.80))
    ]
    assert all(e.height_estimated for e in est)
    same, [note] = one_subject(est)  # one height for the subject, as one mass
    assert [x.height for x in same] == [pytest.approx(1.75)] * 2 and "1.700, 1.800" in note
    assert one_subject(same) == (same, [])  # pooled already: nothing changes
    with_recorded, _ = one_subject([t, *est])  # a trial's recorded height is the subject's
    assert [x.height for x in with_recorded] == [t.height] * 3
    alone, [note] = one_subject([t, est[0]])  # one estimated trial beside it too
    assert [x.height for x in alone] == [t.height] * 2 and "one height" in note
    assert one_subject(alone)[1] == []  # and then nothing more to do
    with pytest.raises(InputError, match="recorded heights differ"):
        one_subject([dataclasses.replace(e, height_source="given (height=)") for e in est])


def test_belt_velocity_and_speed_are_inverse():
    from gc_ocp.trial import belt_velocity

    t = dataclasses.replace(c3d_trial(), belt_velocity=belt_velocity(1.2))
    assert t.belt_speed == 1.2 and t.belt_velocity.tolist() == [-1.2, 0.0, 0.0]


def test_a_plate_ringing_after_toe_off_is_not_fitted_and_the_fit_says_so(walk):
    """Camargo's plate rings from -151 to +97 N in the 30 ms after a toe-off; its frames were
    fitted as the foot's force (92 % of that fit's data cost). The same ringing put after the
    bundled trial's first stance, starting exactly on a marker frame: the margin's frames stop
    before it (that frame too), the stance's own frames are all kept, the fit's notes name the
    plate; with a contact threshold above the ringing (load_trial(stance_threshold=...)) the
    margin is whole."""
    from gc_ocp.stance import quiet_margins, stance_data
    from gc_ocp.workflow.fitting import MARGIN, fit_data

    t, k = walk
    st = t.stances[0]
    plate = t.plates[st.plate]
    assert quiet_margins(t, st, MARGIN)[2] == []  # the real file is quiet there
    frames = k.feet[st.side].time
    first_loud = frames[frames > st.t_off + 0.005][0]  # a marker frame inside the margin
    force = plate.force.copy()
    ring = (plate.time >= first_loud - 1e-9) & (plate.time <= st.t_off + MARGIN)
    force[ring, 2] = -151.0 * np.cos(2 * np.pi * 60 * (plate.time[ring] - first_loud))
    plates = list(t.plates)
    plates[st.plate] = dataclasses.replace(plate, force=force)
    rung = dataclasses.replace(t, plates=tuple(plates))
    t_lo, t_hi, [reason] = quiet_margins(rung, st, MARGIN)
    assert t_lo < st.t_on - MARGIN and abs(t_hi - first_loud) < 1e-6
    assert f"plate {plate.name} reads -151 N" in reason and "after toe-off" in reason
    clean, cut = stance_data(t, k, st, MARGIN), stance_data(rung, k, st, MARGIN)
    assert cut.foot.time[-1] < first_loud <= clean.foot.time[-1]
    assert cut.in_contact.sum() == clean.in_contact.sum()  # the stance itself is whole
    # the plate signal a clock offset shifts holds the foot's zero from the ringing on, and
    # the plate's samples up to it, both band-limited for the frames (gc_ocp.antialias):
    # the low-pass spreads the foot's own last, sub-threshold force (< 20 N at toe-off) into
    # the zeros by a few N, nothing of the 151 N ringing
    ringing = cut.plate_time >= first_loud - 1e-9
    assert ringing.any() and np.abs(cut.plate_wrench[ringing]).max() < 0.05 * 151.0
    same = np.isin(clean.plate_time, cut.plate_time[~ringing])
    # before it, the two differ only by what the filter's tails carry back of the real file's
    # quiet samples after first_loud (under 20 N) against the zeros: under 1 N
    np.testing.assert_allclose(cut.plate_wrench[~ringing], clean.plate_wrench[same], atol=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        notes = fit_data([(rung, k)])[2]
    assert any(st.label in n and "after toe-off" in n for n in notes)
    high = dataclasses.replace(rung, contact_threshold=200.0)  # the detector's own definition
    assert quiet_margins(high, st, MARGIN)[2] == []
    assert stance_data(high, k, st, MARGIN).foot.time.size == clean.foot.time.size


def test_another_load_before_heel_strike_is_not_the_foots(walk):
    """The other side of :func:`~gc_ocp.stance.without_other_loads`: a plate loaded 60 ms
    before the heel strike (the other foot leaving it) holds the foot's zero up to that load's
    last sample, and the plate's own samples after it."""
    from gc_ocp.stance import without_other_loads

    t, _ = walk
    st = t.stances[0]
    plate = t.plates[st.plate]
    force = plate.force.copy()
    load = (plate.time >= st.t_on - 0.08) & (plate.time <= st.t_on - 0.06)
    force[load, 2] = 300.0
    plates = list(t.plates)
    plates[st.plate] = dataclasses.replace(plate, force=force)
    other = dataclasses.replace(t, plates=tuple(plates))
    times = plate.time[(plate.time > st.t_on - 0.1) & (plate.time < st.t_off)]
    wrench = other.stance_wrench(st, times)
    kept = without_other_loads(other, st, times, wrench)
    last = times[load[np.isin(plate.time, times)]][-1]
    assert not kept[times <= last].any()
    assert np.array_equal(kept[times > last], wrench[times > last])


def test_a_contact_threshold_that_finds_no_stance_is_a_clear_error(walk):
    """A non-positive threshold is refused on load; one above every plate's force leaves a
    trial without stances, which the fit names (it raised an IndexError in the LLS start)."""
    import gc_ocp
    from gc_ocp.errors import InputError

    with pytest.raises(InputError, match="stance_threshold=-5: .*positive number"):
        gc_ocp.load_trial(stance_threshold=-5)
    t, k = walk
    empty = dataclasses.replace(t, stances=(), excluded_stances=(), contact_threshold=5000.0)
    with pytest.raises(PlateError, match="no usable stance .*5000 N"):
        gc_ocp.fit([(empty, k)])


def test_load_trial_finds_a_trcs_ground_reactions_beside_it(tmp_path):
    """Python's load_trial pairs a TRC as the command line does (its folder's one .mot), with a
    warning naming the file; a TRC with none beside it names the fix."""
    import shutil

    from conftest import RAJ

    import gc_ocp
    from gc_ocp.errors import InputError

    if not RAJ.is_dir():
        pytest.skip(f"real datasets not found at {RAJ}")
    shutil.copy(RAJ / "motion_capture_walk.trc", tmp_path / "walk.trc")
    with pytest.raises(InputError, match="without ground reactions.*--grf"):
        gc_ocp.load_trial(tmp_path / "walk.trc", mass=85.07)
    shutil.copy(RAJ / "grf_walk.mot", tmp_path / "grf_walk.mot")
    with pytest.warns(UserWarning, match="ground reactions from .*grf_walk.mot"):
        trial = gc_ocp.load_trial(tmp_path / "walk.trc", mass=85.07)
    assert trial.grf_source == tmp_path / "grf_walk.mot" and len(trial.stances) == 3
