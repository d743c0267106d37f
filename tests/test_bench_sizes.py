"""Benchmark cases on a chosen number of stances per foot (``bench.truth.per_foot``)."""

from __future__ import annotations

import numpy as np
import pytest

from gc_ocp.bench.truth import motion, per_foot
from gc_ocp.diagnosis.compare import fold_plan
from gc_ocp.errors import InputError


def test_stances_per_foot_repeat_strides_as_further_trials():
    real = motion("registered")  # the bundled trial: two right stances, one left
    sides = [st.side for st in real]
    assert sides.count("right") == 2 and sides.count("left") == 1
    four = per_foot(real, 4)
    assert [st.side for st in four].count("right") == 4
    assert [st.side for st in four].count("left") == 4
    assert len({st.label for st in four}) == 8  # every stance its own label ...
    repeats = [st for st in four if "~" in st.trial]
    assert len({st.trial for st in four}) == 4  # ... and every repetition its own trial
    for st in repeats:  # a repeat walks the real stride's motion
        src = next(r for r in real if r.label.split(":", 1)[1] == st.label.split(":", 1)[1])
        np.testing.assert_array_equal(st.foot.hindfoot_pose, src.foot.hindfoot_pose)
        assert st.label.startswith(st.trial + ":")
    assert len(fold_plan(four)) == 8  # every stance can be held out
    one = per_foot(real, 1)
    assert [st.label for st in one] == [
        real[0].label,
        next(s for s in real if s.side == "left").label,
    ]
    with pytest.raises(InputError, match="at least 1"):
        per_foot(real, 0)
