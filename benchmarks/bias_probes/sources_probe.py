"""One-off probe (issue 23; README.md beside it): which of the coverage benchmark's error
sources gives mu its error under a drift per stance? The benchmark's six stances, each source
drawn from its own random stream (so a source's draw is the same whichever others are on):
``plate`` (AR(1) plate noise, 1 % BW, rho 0.9), ``marker`` (0.5 mm of white marker noise,
low-passed), ``drift`` (3 mm / 0.75 deg per stance: offset and trend), ``drift+marker``, ``all``.

``sources_probe.py VARIANT SEEDS [MM DEG [no-noise-part]]``: per seed, the fit (widths
estimated, as gc_ocp.fit; with MM DEG: the pose widths fixed there, the sole's 5 mm prior;
``no-noise-part``: the pose correction without its measured-noise part; ``knots=S``: its
smooth part's knot spacing S seconds, default 0.1), mu's error and SE, n's error."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from sources_probe_data import FLAGS, fitted, make, with_pose  # noqa: E402

from gc_ocp.estimation.synthetic import recovery_model

variant = sys.argv[1]
flags = FLAGS[variant]
fixed = [float(a) for a in sys.argv[3:5]] if len(sys.argv) > 4 else None
for seed in [int(a) for a in sys.argv[2].split(",")]:
    data = make(seed, *flags)
    model = recovery_model(marker_noise="no-noise-part" not in sys.argv)
    for a in sys.argv:
        if a.startswith("knots="):
            model = with_pose(model, knot_spacing=float(a[6:]))
    _, res = fitted(data, model, fixed)
    print(
        variant,
        seed,
        f"mu err {res.params['shared']['mu'] - 0.8:+.4f} se {res.params['shared']['mu_se']:.4f}",
        f"n err {res.params['shared']['n'] - 1.5:+.4f}",
        flush=True,
    )
