"""The withheld-effect benchmark's plumbing (``gc_ocp.bench.withheld``) on a small case: a
strong clock offset and "none", one seed, two candidates, against the bare seed base (the
cheapest fits: the law alone). The full benchmark is ``gc-ocp benchmark-diagnosis``
(``benchmarks/diagnosis_blind_output.md``)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from gc_ocp.bench import withheld as benchmark
from gc_ocp.errors import InputError
from gc_ocp.estimation.components import REGISTRY

import withheld_reference as reference  # isort: skip (a test helper beside this file)


def test_plan_covers_every_truth_and_rejects_unknown_names():
    cases = benchmark.plan("registered", seeds=2)
    truths = {c["truth"] for c in cases}
    # the registered base has sole and pose corrections: they are not candidates
    assert truths == {
        "damping",
        "stiffness_exponent",
        "contact_density",
        "toe_joint",
        "ground_offset",
        "time_offset",
        "friction",
        "none",
    }
    assert len(cases) == 8 * 2 * 2
    # "none" gets distinct seeds, as many cases as an effect
    assert sorted(c["seed"] for c in cases if c["truth"] == "none") == [0, 1, 2, 3]
    assert len({c["seed"] for c in benchmark.plan("seed", seeds=1) if c["truth"] == "none"}) == 2
    with pytest.raises(InputError, match="not candidates on base 'registered'"):
        benchmark.plan("registered", effects=["sole_geometry"])
    with pytest.raises(InputError, match="Unknown magnitude"):
        benchmark.plan("seed", magnitudes=["huge"])


def test_generator_thresholds_the_plate_and_drifts_the_foot():
    """Frames below 20 N are zero on the plate; the seen foot differs from the true one by the
    drift (a few mm), the true motion is untouched."""
    stances = benchmark.motion("seed")
    truth = benchmark.base_truth("seed")
    rng = np.random.default_rng(0)
    data = benchmark.generate(stances, truth, rng, benchmark.Realism(), (0.0, 2e-3, 0.5))
    for st, d in zip(stances, data, strict=True):
        low = d.measured[:, 2] < 20.0
        assert low.any() and np.all(d.measured[low] == 0.0)
        moved = np.linalg.norm(d.foot.positions - st.foot.positions, axis=2)
        assert 1e-4 < np.median(moved) < 1e-2  # [m]


def _same(a, b) -> bool:
    """Exact equality of truths: components field by field, arrays bit for bit."""
    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and all(
            _same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
        )
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.asarray(a).dtype == np.asarray(b).dtype and np.array_equal(a, b)
    return type(a) is type(b) and a == b


@pytest.mark.parametrize("base", ["seed", "registered"])
def test_injected_truths_are_those_of_the_former_if_chain(base):
    """Every effect (and "none") at both magnitudes: the same components with the same fixed
    values, the same true motion, the same kinematic error and the same random draws as the
    benchmark built before the effects declared their injection (``withheld_reference``)."""
    former = {e: {m: v[m] for m in ("moderate", "strong")} for e, v in _values().items()}
    assert former == reference.VALUES
    assert list(benchmark.injected_values()) == list(
        reference.VALUES
    )  # the order of confusion.json
    _, base_model_ = benchmark.resolve_base(base)
    frozen = benchmark.base_truth(base)
    for effect in [*reference.EFFECTS, "none"]:
        stances = benchmark.motion(base, effect)
        old_stances = reference.motion(base, effect)
        for st, old in zip(stances, old_stances, strict=True):
            assert np.array_equal(st.foot.points_local, old.foot.points_local), effect
        for mag in ("moderate", "strong"):  # the former chain's (small came later)
            rng, old_rng = np.random.default_rng(11), np.random.default_rng(11)
            truth = benchmark.truth_model(effect, mag, frozen, stances, rng)
            old = reference.truth_model(effect, mag, frozen, stances, old_rng)
            assert _same(truth, old), (effect, mag)
            assert rng.bit_generator.state == old_rng.bit_generator.state, (effect, mag)
            realism = benchmark.Realism()
            assert benchmark.kinematic_error(effect, mag, base_model_, realism) == (
                reference.kinematic_error(effect, mag, base_model_, realism)
            ), (effect, mag)
    assert not _same(  # the comparison can fail: another draw gives other offsets
        benchmark.truth_model("sole_geometry", "strong", frozen, stances, np.random.default_rng(1)),
        benchmark.truth_model("sole_geometry", "strong", frozen, stances, np.random.default_rng(2)),
    )


def _values() -> dict:
    return benchmark.injected_values()


NEUTRAL = {  # each effect's value at which the model is the base's (its component's docs)
    "damping": 0.0,  # c [s/m]
    "stiffness_exponent": 1.0,  # n: the base's linear law
    "sole_geometry": 0.0,  # no offset
    "kinematic_correction": (0.0, 0.0, 0.0),  # no marker error
    "contact_density": 1.0,  # heel and toe alike
    "toe_joint": 0.0,  # no dorsiflexion
    "ground_offset": (0.0, 0.0),  # level floor at 0
    "time_offset": 0.0,  # plate on time
    "friction": (0.0, 0.0),  # Coulomb: no static excess, no viscous part
}


def test_small_magnitude_is_half_the_moderate_departure_from_neutral():
    """Every injectable effect declares the three magnitudes, and "small" is where its doc puts
    it: the midpoint of neutral and moderate (exact in binary for these decimals up to one
    rounding, hence the 1e-12)."""
    values = _values()
    assert set(values) == set(NEUTRAL)
    for effect, v in values.items():
        assert tuple(v) == benchmark.MAGNITUDES, effect
        mid = np.asarray(NEUTRAL[effect]) + 0.5 * (
            np.asarray(v["moderate"]) - np.asarray(NEUTRAL[effect])
        )
        np.testing.assert_allclose(np.asarray(v["small"]), mid, rtol=1e-12, err_msg=effect)


def test_a_magnitude_an_effect_does_not_declare_is_refused(monkeypatch):
    """An effect registered elsewhere may declare only some magnitudes: asking it for another
    names the effect and what it declares, no KeyError from the middle of a run."""
    cls = REGISTRY["damping"]
    monkeypatch.setattr(cls, "benchmark_values", {"moderate": 0.5, "strong": 1.0})
    frozen = benchmark.base_truth("seed")
    stances = benchmark.motion("seed", "damping")
    with pytest.raises(InputError, match=r'"damping" declares no "small".*moderate'):
        benchmark.truth_model("damping", "small", frozen, stances, np.random.default_rng(0))


@pytest.mark.slow
def test_strong_effect_is_found_and_none_rejected(tmp_path):
    res = benchmark.run_benchmark(
        tmp_path,
        base="seed",
        effects=["time_offset", "none"],
        seeds=1,
        magnitudes=["strong"],
        candidates=["time_offset", "damping"],
        n_boot=500,
        workers=1,
    )
    saved = json.loads((tmp_path / "confusion.json").read_text())
    assert (tmp_path / "confusion.png").stat().st_size > 0
    assert saved["summary"] == json.loads(json.dumps(res["summary"]))
    by_truth = {c["truth"]: c for c in saved["cases"]}
    print(benchmark.report(res))
    for c in saved["cases"]:
        print(
            c["truth"],
            "->",
            c["answer"],
            [(r["effect"], r["heldout_rms_reduction_pct"]) for r in c["ranking"]],
        )
    assert by_truth["time_offset"]["answer"] == "time_offset"
    assert by_truth["none"]["answer"] == "none"
    s = saved["summary"]
    assert s["top1_accuracy"] == 1.0 and s["none_correct_rejection"] == 1.0
    assert s["matrix"] == [[1, 0, 0], [0, 0, 1]]  # rows time_offset, none; columns + damping
    # every case records its rounds' nulls: the draws made, whether they stopped, the looks
    for c in saved["cases"]:
        assert c["null"] and all(n["mismatch_draws"] >= 1 and n["seconds"] > 0 for n in c["null"])
        assert all(isinstance(n["null_stopped_early"], bool) for n in c["null"])


def _fake_evaluation(frame_costs: list[np.ndarray]):
    """An Evaluation-like object with held-out per-frame costs (no prior, no Occam term)."""
    from types import SimpleNamespace

    from gc_ocp.diagnosis.compare import Evaluation, Fold

    folds = []
    for i, c in enumerate(frame_costs):
        fit = {
            "time": np.arange(c.size) / 100.0,  # 100 Hz: the blocks' length in frames
            "model": np.zeros((c.size, 6)),
            "measured": np.zeros((c.size, 6)),
            "in_contact": np.ones(c.size, bool),
            "body_weight": 600.0,
        }
        held = SimpleNamespace(
            data_cost=float(c.sum()), prior_cost=0.0, n_data=6 * c.size, stance_fits=[fit]
        )
        folds.append(Fold(f"s{i}", None, held, 0.0, c))
    full = SimpleNamespace(objective=float(sum(c.sum() for c in frame_costs)))
    return Evaluation("x", (), (), full, folds)


def test_tied_candidates_are_named_confounded():
    """Two passing candidates whose paired held-out difference is within the bootstrap noise
    are named confounded with each other; a clearly better one is not tied to a worse one."""
    from gc_ocp.diagnosis.result import RankRow
    from gc_ocp.diagnosis.selection import flag_ties

    rng = np.random.default_rng(0)
    base = [np.full(60, 1.0) for _ in range(3)]
    a = [c * 0.8 * (1 + 0.02 * rng.standard_normal(c.size)) for c in base]
    b = [c * 0.8 * (1 + 0.02 * rng.standard_normal(c.size)) for c in base]  # same as a
    w = [c * 0.95 for c in base]  # passes too, clearly worse than a and b
    evs = {n: _fake_evaluation(v) for n, v in {"a": a, "b": b, "w": w}.items()}
    rows = [
        RankRow(n, 1.0, (0.5, 1.5), 1.0, 1.0, {}, 1, True, False, False, None, (), ())
        for n in ("a", "b", "w")
    ]
    rows = flag_ties(rows, evs, 500, 0, 100.0)
    by = {r.effect: r.confounded_with for r in rows}
    assert by == {"a": ("b",), "b": ("a",), "w": ()}


def test_a_case_that_stops_with_an_error_is_an_answer_of_its_own():
    """A case whose diagnosis stops (the base's fit did not converge on its data) is kept as
    the answer "error" with its message: counted, not right, its own column of the confusion
    matrix, and the summary of the other cases unchanged in kind."""
    from gc_ocp.errors import SolveError

    case = {"truth": "damping", "magnitude": "moderate", "seed": 0}
    row = benchmark.failed_case(case, SolveError("Ipopt did not converge: x"), 12.0)
    assert row["answer"] == benchmark.ERROR and not row["correct"]
    assert row["error"] == "SolveError: Ipopt did not converge: x"
    ok = {**row, "answer": "damping", "correct": True, "truth": "damping", "seed": 1}
    none = {**row, "truth": "none", "magnitude": "-", "answer": "none", "correct": True}
    s = benchmark.summarize([row, ok, none], ["damping", "none"])
    assert s["answers"] == ["damping", "none", "error"]
    assert s["matrix"] == [[1, 0, 1], [0, 1, 0]]
    assert s["top1_accuracy"] == 0.5 and s["none_correct_rejection"] == 1.0
    json.dumps(row)  # plain data, as confusion.json keeps it


def test_resume_names_the_settings_that_differ_instead_of_starting_again(tmp_path):
    """``--resume`` on a run made with other settings is refused with the keys that differ (it
    used to start again silently and overwrite the earlier cases); trial paths are compared
    resolved, so the same files written another way are the same run."""
    old = {"n_boot": 5, "motion_files": [str(tmp_path / "a" / ".." / "w.c3d")], "seeds": [0]}
    same = {"n_boot": 5, "motion_files": [str(tmp_path / "w.c3d")], "seeds": [0]}
    assert benchmark.settings_differ(old, same) == []
    assert benchmark.settings_differ(old, {**same, "n_boot": 7, "seeds": [1]}) == [
        "n_boot",
        "seeds",
    ]
    out = tmp_path / "run"
    out.mkdir()
    (out / "confusion.json").write_text(json.dumps({"settings": {"n_boot": 5}, "cases": []}))
    with pytest.raises(InputError, match=r"--resume: .*confusion.json.*n_boot.*differ"):
        benchmark.run_benchmark(out, base="seed", effects=["none"], seeds=1, n_boot=7, resume=True)


def test_the_null_s_family_reaches_the_diagnosis_and_the_settings(tmp_path, monkeypatch):
    """``null_family`` (``--plate-calibration null``) is the family every case's diagnosis
    draws its null from; the default hands the diagnosis
    :data:`~gc_ocp.diagnosis.null.DEFAULT_FAMILY` (what the settings record: the next test).
    The diagnosis is stopped at its call (what it was given is the point, not its answer)."""
    from gc_ocp.diagnosis.null import DEFAULT_FAMILY

    seen = []

    class Given(Exception):
        pass

    def spy(*args, mismatch, **kw):
        seen.append(mismatch)
        raise Given

    monkeypatch.setattr(benchmark, "diagnose_stances", spy)
    plates = DEFAULT_FAMILY.with_plate_calibration()
    for family, out in ((None, tmp_path / "default"), (plates, tmp_path / "plates")):
        with pytest.raises(Given):
            benchmark.run_benchmark(
                out, base="seed", effects=["none"], seeds=1, n_boot=7, null_family=family
            )
    assert seen == [DEFAULT_FAMILY, plates] and plates.plate_calibration


def test_the_default_null_family_leaves_the_settings_as_they_were(tmp_path, monkeypatch):
    """No ``null_family``, or the default given explicitly: the settings a ``--resume`` compares
    have no ``null_family`` key, as in every run made before it could be chosen (else no
    earlier run resumes); the plate family's settings have it."""
    from gc_ocp.diagnosis.null import DEFAULT_FAMILY

    recorded = []
    real = benchmark.settings_differ
    monkeypatch.setattr(
        benchmark, "settings_differ", lambda old, new: recorded.append(new) or real(old, new)
    )
    (tmp_path / "confusion.json").write_text(json.dumps({"settings": {}, "cases": []}))
    plates = DEFAULT_FAMILY.with_plate_calibration()
    for family in (None, DEFAULT_FAMILY, plates):
        with pytest.raises(InputError, match="--resume"):
            benchmark.run_benchmark(
                tmp_path,
                base="seed",
                effects=["none"],
                seeds=1,
                n_boot=7,
                resume=True,
                null_family=family,
            )
    # so a run with the default null does not resume into one with the plate member
    assert [("null_family" in r) for r in recorded] == [False, False, True]
