"""Would low-pass filters belong in the measurement model? Two measurements on the bundled motion
(issue 22, item 1: "a filtered measurement is compared with the filtered model").

    .venv/bin/python benchmarks/lowpass_measurement.py   # writes lowpass_measurement_output.md

1. **The markers' low-pass** (the model's kinematics are filtered, the plates' forces are not).
   The lab's remedy is to filter the plates at the markers' cutoff too (compare like with like).
   Here: plates of the bundled motion's registered truth (no noise), the motion the fitter sees
   low-passed at a cutoff (``diagnosis.mismatch.lowpassed``, effective order 4), the registered
   base refitted (a) to the raw plates and (b) to the plates low-passed at the same cutoff
   (zero-lag Butterworth, effective order 4, the stance window padded by reflection): the force
   RMS of each refit against its own plates [% BW] (what is left unexplained) and the in-sample
   gain of a clock offset on top [%] (what a candidate would absorb).
2. **The plates' low-pass** (``.mot`` files filtered at ~20 Hz): the model's wrench would have to
   be filtered at that cutoff before the comparison. Here: how much low-passing the fitted
   model's wrench at a cutoff changes it [% BW, RMS and largest], on the base's fit of the
   bundled trial's real data.
"""

from __future__ import annotations

import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.signal import butter, filtfilt

sys.path.insert(0, str(Path(__file__).parent))
from mismatch_sizes import clean, fit, force_rms  # noqa: E402

from gc_ocp.bench.recovery import bundled_base_truth  # noqa: E402
from gc_ocp.diagnosis import mismatch as mm  # noqa: E402
from gc_ocp.estimation.components import base_model, model_from_names  # noqa: E402

HERE = Path(__file__).parent
MARKER_CUTOFFS = (4.0, 6.0, 8.9)  # the mismatch family's range (4-10 Hz) and the bundled trial's
PLATE_CUTOFFS = (10.0, 15.0, 20.0, 26.0)  # the .mot files' estimated cutoffs are ~19-26 Hz


def lowpass(x: np.ndarray, fc: float, rate: float) -> np.ndarray:
    b, a = butter(mm.FILTER_ORDER // 2, fc / (rate / 2))
    return filtfilt(b, a, x, axis=0, padlen=x.shape[0] - 1)


def rate_of(st) -> float:
    return 1.0 / float(np.median(np.diff(st.time)))


def main() -> None:
    t0 = time.perf_counter()
    warnings.simplefilter("ignore")
    stances, truth = bundled_base_truth()
    data0 = clean(stances, truth)
    r0 = force_rms(fit(data0, base_model()), data0)
    lines = [
        "# Low-pass filters and the measurement model (`benchmarks/lowpass_measurement.py`)",
        "",
        f"Bundled motion, its registered truth, no plate noise; refit of the unchanged data "
        f"{r0:.3f} % BW (force RMS, 3 channels).",
        "",
        "## 1. The markers' low-pass: plates raw, or low-passed at the markers' cutoff",
        "",
        "| marker cutoff [Hz] | refit to raw plates [% BW] | refit to low-passed plates [% BW] "
        "| clock offset's in-sample gain, raw | ... low-passed |",
        "|---|---|---|---|---|",
    ]
    to = model_from_names(["time_offset"], base=base_model())
    for fc in MARKER_CUTOFFS:
        seen = [d.with_foot(mm.lowpassed(s.foot, fc)) for d, s in zip(data0, stances, strict=True)]
        filt = [dataclasses.replace(s, measured=lowpass(s.measured, fc, rate_of(s))) for s in seen]
        cells = []
        gains = []
        for d in (seen, filt):
            f = fit(d, base_model())
            cells.append(f"{force_rms(f, d):.3f}")
            g = fit(d, to, start=f)
            gains.append(f"{100 * (1 - np.sqrt(g.objective / f.objective)):.1f} %")
        lines.append(f"| {fc:g} | {cells[0]} | {cells[1]} | {gains[0]} | {gains[1]} |")
    lines += [
        "",
        "## 2. The plates' low-pass: the model's wrench low-passed at the plate's cutoff",
        "",
        "| cutoff [Hz] | change of the model wrench, RMS [% BW] | largest [% BW] |",
        "|---|---|---|",
    ]
    real = stances  # the bundled trial's real stances, as loaded (real plates)
    res = fit(real, base_model())
    bw = real[0].body_weight
    for fc in PLATE_CUTOFFS:
        d = np.concatenate(
            [
                (lowpass(np.asarray(f["model"]), fc, rate_of(st)) - np.asarray(f["model"]))[:, :3]
                for f, st in zip(res.stance_fits, real, strict=True)
            ]
        )
        lines.append(
            f"| {fc:g} | {100 * np.sqrt(np.mean(d**2)) / bw:.3f} | {100 * np.abs(d).max() / bw:.2f} |"
        )
    lines += ["", f"Run time {time.perf_counter() - t0:.0f} s."]
    text = "\n".join(lines) + "\n"
    (HERE / "lowpass_measurement_output.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
