"""The JSON documents the package writes are strict JSON (no ``NaN``/``Infinity`` words, which
JavaScript, jq and R's jsonlite refuse), and a number that was not finite comes back as NaN."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import strict_json as strict_loads  # noqa: E402

from gc_ocp.text import json_text, nan_for_null

FIXTURES = Path(__file__).parent / "report_fixtures"


def test_json_text_writes_null_for_what_is_not_finite_and_numpy_as_numbers():
    doc = {
        "se": float("nan"),
        "inf": [1.0, float("inf"), -np.inf],
        "np": {"f": np.float64(np.nan), "i": np.int64(3), "b": np.bool_(True)},
        "array": np.array([[1.5, np.nan]]),
        "tuple": (np.float32(2.5), None, "text"),
    }
    with pytest.raises(ValueError, match="not strict JSON"):  # the check itself can fail
        strict_loads(json.dumps({"se": float("nan")}))
    back = strict_loads(json_text(doc))
    assert back == {
        "se": None,
        "inf": [1.0, None, None],
        "np": {"f": None, "i": 3, "b": True},
        "array": [[1.5, None]],
        "tuple": [2.5, None, "text"],
    }
    restored = nan_for_null(back["inf"])
    assert restored[0] == 1.0 and math.isnan(restored[1]) and math.isnan(restored[2])


def test_a_fit_json_with_not_finite_numbers_is_strict_and_reads_them_back_as_nan():
    from gc_ocp.estimation.result import EstimationResult

    doc = json.loads((FIXTURES / "all_effects" / "final_fit.json").read_text())
    # a unit whose standard error is not identified, a foot with no COP sample
    doc["blocks"]["contact"]["left"]["PL"]["k_se"] = float("nan")
    doc["rms"]["left"]["superior_force_pct_bw"] = float("nan")
    doc["cop_rms_mm"]["right"] = float("nan")
    r = EstimationResult.from_json(doc)
    text = json_text(r.to_json())
    back = EstimationResult.from_json(strict_loads(text))
    assert math.isnan(back.params["left"]["PL"]["k_se"])
    assert math.isnan(back.rms["left"]["superior_force_pct_bw"])
    assert math.isnan(back.cop_rms_mm["right"])
    # the rest as it was, and the summary (which formats every figure) is the same
    assert back.params["left"]["PM"] == r.params["left"]["PM"]
    np.testing.assert_array_equal(back.x, r.x)
    assert back.summary() == r.summary()
    assert back.covariance is None  # a null that means "not kept" stays None


def test_a_diagnosis_row_with_not_finite_numbers_is_strict_and_reads_them_back():
    from gc_ocp.diagnosis import Diagnosis
    from gc_ocp.diagnosis.result import RankRow

    d = Diagnosis.from_json(json.loads((FIXTURES / "all_effects" / "diagnosis.json").read_text()))
    row = next(r for r in d.ranking if r.calibrated is not None)
    odd = dataclasses.replace(
        row,
        insample_rms_reduction_pct=float("nan"),  # typed float: NaN comes back NaN
        heldout_rms_reduction_pct=None,  # typed float | None: None stays None
        calibrated=dataclasses.replace(row.calibrated, z=float("nan")),
    )
    back = RankRow.from_json(strict_loads(json_text(odd.to_json())))
    assert math.isnan(back.insample_rms_reduction_pct) and math.isnan(back.calibrated.z)
    assert back.heldout_rms_reduction_pct is None
    assert back.calibrated.p_adjusted == row.calibrated.p_adjusted
    doc = d.to_json()
    doc["waterfall"][0]["score"] = float("nan")
    again = Diagnosis.from_json(strict_loads(json_text(doc)))
    assert math.isnan(again.waterfall[0].score)
    assert again.summary().count("\n") == d.summary().count("\n")
