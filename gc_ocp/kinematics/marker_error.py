"""The markers' error of a trial as the fit reports it (:mod:`gc_ocp.marker_noise` measures it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

OUTLIER_FACTOR = 3.0
"""A marker whose white noise exceeds this many times the median of its class's other markers
(of the trial's other markers when it is its class's only one), and :data:`OUTLIER_MM`, is
named (a loose marker, a reconstruction that swaps two markers, a wrong camera calibration).
The marker itself is left out of the median: in a class of two (a Davis or Helen Hayes foot's
heel and toe) or one (a Plug-in Gait shank) it would be half or all of it, and no marker could
exceed three times a median it makes."""

OUTLIER_MM = 1.0
"""[mm] Below this a marker's noise is not worth a word whatever its class's median (current
camera systems reconstruct markers to 0.05-0.5 mm; a lab that low-passed its markers shows
~0.01 mm, and a ratio to that alone would name ordinary markers)."""


@dataclass(frozen=True)
class MarkerError:
    """The markers' error of one trial (module doc): ``white_mm`` per marker, ``classes`` its
    class (the model segment it sits on), ``band_hz`` the lower edge of the band the noise was
    read in (:func:`~gc_ocp.marker_noise.noise_band_hz` of the trial's marker rate), and the
    markers far above their class's other markers (:meth:`outliers`)."""

    white_mm: dict[str, float]
    classes: dict[str, str]
    band_hz: float

    def per_class(self) -> dict[str, float]:
        """The median white noise [mm] of each class."""
        out: dict[str, list[float]] = {}
        for n, v in self.white_mm.items():
            if np.isfinite(v):
                out.setdefault(self.classes[n], []).append(v)
        return {c: float(np.median(v)) for c, v in sorted(out.items())}

    def outliers(self) -> list[str]:
        """Markers whose noise exceeds :data:`OUTLIER_FACTOR` times the median of their class's
        other markers (the trial's other markers for a class's only marker), and
        :data:`OUTLIER_MM`, each with its figure and what to check."""
        finite = {n: v for n, v in self.white_mm.items() if np.isfinite(v)}
        out = []
        for n, v in finite.items():
            c = self.classes[n]
            same = [w for m, w in finite.items() if m != n and self.classes[m] == c]
            ref = same or [w for m, w in finite.items() if m != n]
            if not ref:
                continue
            med = float(np.median(ref))
            if v > max(OUTLIER_FACTOR * med, OUTLIER_MM):
                what = "its class's other markers'" if same else "the trial's other markers'"
                ratio = f"{v / med:.1f}x " if med > 0 else ""
                out.append(
                    f"marker {n} ({c}): white noise {v:.2f} mm, {ratio}{what} median "
                    f"{med:.2f} mm; check its reconstruction (a loose or swapped marker)"
                )
        return out

    def to_json(self) -> dict:
        return {
            "white_mm_per_class": self.per_class(),
            "white_mm": {n: (None if not np.isfinite(v) else v) for n, v in self.white_mm.items()},
            "outliers": self.outliers(),
            "method": f"MAD of the residual above {self.band_hz:g} Hz (gc_ocp.marker_noise)",
        }


__all__ = ["MarkerError"]
