"""Reproduction of the seed report's Tables 1 and 2.

:func:`reproduce_seed` fits the seed's LLS (n = 1, c = 0, friction mu = 0.5, see
:mod:`gc_ocp.contact.lls`) to the four synthetic sets of :mod:`gc_ocp.contact.synthetic`, driven
by the trial's own motion and stances, and to the trial's measured wrenches.

Table 1 rows (in this order) have the keys ``case``, ``k_rms_pct``, then one key per channel of
:data:`~gc_ocp.contact.channels.CHANNELS` (``anterior_force_pct_bw``, ...,
``mediolateral_torque_pct_bwh``); noisy rows (mean over ``seeds`` draws) add the same keys with
``_sd`` (sample standard deviation). Synthetic rows are normalised as in the seed: k by
11,974 N/m, forces by BW = 689 N, torques by BW*H = 1,173 N·m; the experimental row by the
trial's own BW and BW*H (H: the trial's height, else the one the kinematics estimated and
scaled the body with, else the seed's BW*H / BW). Table 2 is the experimental
``{side: {unit: k [N/m]}}``.

The four tables are written as one set (:func:`write_tables`): all of them, replacing an
earlier run's, or none.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from gc_ocp.contact.channels import (
    CHANNELS,
    SEED_BW,
    SEED_BWH,
    SEED_K_UNIFORM,
    TABLE_KEYS,
    k_rms_pct,
)
from gc_ocp.contact.equivalent_wrench import LawParams
from gc_ocp.contact.lls import SEED_LAW, fit_stiffness_lls, stances_from_trial
from gc_ocp.contact.synthetic import (
    DEFAULT_DEPTH,
    SYNTHETIC_CASES,
    auto_ground_heights,
    draw_case,
    synthetic_stances,
)
from gc_ocp.errors import InputError
from gc_ocp.foot import UNITS
from gc_ocp.outputs import OutputSet, atomic_write_text  # noqa: F401  (re-exported)
from gc_ocp.stance import StanceData
from gc_ocp.text import json_text

TABLE1_CASES: tuple[str, ...] = (*SYNTHETIC_CASES, "experimental")
TABLE1_KEYS: tuple[str, ...] = ("case", "k_rms_pct", *(TABLE_KEYS[c] for c in CHANNELS))
"""Keys of every Table 1 row, in order; noisy rows append ``<key>_sd`` for the numeric keys."""

SEED_TABLE1: dict[str, dict[str, float | None]] = {
    case: dict(zip(TABLE1_KEYS[1:], vals, strict=True))
    for case, vals in {
        "synthetic_noiseless_uniform_k": (
            2.31e-13,
            2.55e-16,
            3.74e-14,
            2.21e-16,
            4.23e-15,
            1.01e-16,
            1.89e-14,
        ),
        "synthetic_noiseless_random_k": (
            2.32e-13,
            2.43e-16,
            3.33e-14,
            2.06e-16,
            3.73e-15,
            7.81e-17,
            1.48e-14,
        ),
        "synthetic_noisy_uniform_k": (3.13, 0.013, 2.27, 0.013, 0.16, 0.0045, 0.74),
        "synthetic_noisy_random_k": (6.59, 0.015, 2.52, 0.014, 0.21, 0.0050, 0.81),
        "experimental": (None, 6.46, 20.26, 1.83, 3.35, 0.29, 7.09),
    }.items()
}
"""The seed report's Table 1 (RMS errors, % uniform k, % BW, % BW*H)."""

SEED_TABLE2: dict[str, dict[str, float]] = {
    "left": {"PL": -4277.15, "PM": 22106.33, "AL": 23587.15, "AM": 70986.77, "TT": 16315.52},
    "right": {"PL": -18437.78, "PM": 36800.79, "AL": 82998.65, "AM": -67927.68, "TT": 13156.56},
}
"""The seed report's Table 2: experimental k [N/m] (first five rows left, last five right)."""

Progress = Callable[[int, int, str], None]


def _row(case: str, k_pct: float | None, rms: dict[str, float]) -> dict:
    row: dict = {"case": case, "k_rms_pct": k_pct}
    row.update({TABLE_KEYS[c]: float(rms[c]) for c in CHANNELS})
    return row


def run_synthetic_case(
    case: str,
    template: list[StanceData],
    feet,
    rng: np.random.Generator,
    law: LawParams = SEED_LAW,
) -> dict:
    """One draw of one synthetic case: generate, fit with nominal points, score (seed normalisers)."""
    sides = sorted({st.side for st in template})
    k_true, offsets = draw_case(case, rng, sides)
    data = synthetic_stances(template, feet, k_true, offsets, law)
    fit = fit_stiffness_lls(data, SEED_BW, SEED_BWH, law)
    kt = np.array([k_true[s][UNITS.index(u)] for s, u in fit.unknowns])
    return _row(case, k_rms_pct(fit.k_vector, kt, SEED_K_UNIFORM), fit.rms_pct)


def reproduce_seed(
    trial,
    kinematics,
    seeds: int = 20,
    out_dir: str | os.PathLike | None = None,
    progress: Progress | None = None,
    law: LawParams = SEED_LAW,
    synthetic_depth: float = DEFAULT_DEPTH,
    rng_seed: int = 0,
) -> dict:
    """Reproduce the seed's Tables 1 and 2 on ``trial`` with its ``kinematics``.

    trial: :class:`~gc_ocp.trial.Trial`; kinematics: ``TrialKinematics`` (``.feet[side]``);
    seeds: number of draws for each noisy case; out_dir: if given, writes ``table1.json``,
    ``table1.md``, ``table2.json``, ``table2.md`` there as one set (:func:`write_tables`);
    progress: ``progress(done, total, label)``; law: contact law of the fit and of the
    synthetic data; synthetic_depth: penetration of the lowest unit at mid-stance in the
    synthetic sets [m] (:func:`auto_ground_heights`);
    rng_seed: base seed (draw d of case i uses ``default_rng([rng_seed, i, d])``).

    Returns ``{"table1": [rows], "table2": {side: {unit: k}}, "experimental_fit": LLSResult,
    "settings": {...}, "notes": [...]}``. Raises :class:`~gc_ocp.errors.RankError` if a fit is
    not identifiable (e.g. a unit never below the plate surface).
    """
    if seeds < 1:
        raise InputError(f"seeds must be >= 1, but got {seeds}")
    notes: list[str] = []
    real = stances_from_trial(trial, kinematics)
    template = auto_ground_heights(real, synthetic_depth)
    total = 2 + 2 * seeds + 1
    done = 0

    def tick(label: str) -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total, label)

    rows = []
    for i, case in enumerate(SYNTHETIC_CASES):
        draws = 1 if "noiseless" in case else seeds
        results = []
        for d in range(draws):
            rng = np.random.default_rng([rng_seed, i, d])
            results.append(run_synthetic_case(case, template, kinematics.feet, rng, law))
            tick(f"{case} draw {d + 1}/{draws}")
        if draws == 1:
            rows.append(results[0])
            continue
        row: dict = {"case": case}
        numeric = TABLE1_KEYS[1:]
        vals = np.array([[r[k] for k in numeric] for r in results])
        row.update({k: float(v) for k, v in zip(numeric, vals.mean(axis=0), strict=True)})
        sd = vals.std(axis=0, ddof=1) if draws > 1 else np.zeros(len(numeric))
        row.update({f"{k}_sd": float(v) for k, v in zip(numeric, sd, strict=True)})
        rows.append(row)

    bw = trial.body_weight
    height = trial.height
    if height is None and kinematics.info.get("height") is not None:
        # the height the kinematics estimated and scaled the body with, as ``fit`` uses it
        height = float(kinematics.info["height"])
        notes.append(
            f"Subject height not given: torques normalised with H = {height:.3f} m, the "
            "kinematics' estimate from the markers (pass the measured height to override)."
        )
    elif height is None:
        height = SEED_BWH / SEED_BW
        notes.append(
            f"Subject height unknown: torques normalised with H = {height:.3f} m "
            "(the seed's BW*H / BW)."
        )
    fit = fit_stiffness_lls(real, bw, bw * height, law)
    tick("experimental")
    rows.append(_row("experimental", None, fit.rms_pct))
    table2 = {side: dict(ks) for side, ks in fit.k.items()}
    result = {
        "table1": rows,
        "table2": table2,
        "experimental_fit": fit,
        "settings": {
            "law": {
                "n": law.n,
                "c": law.c,
                "mu": law.mu,
                "smooth": law.smooth,
                "v_eps": law.smoothing.v_eps,
            },
            "seeds": seeds,
            "rng_seed": rng_seed,
            "synthetic_depth_m": synthetic_depth,
            "synthetic_ground_heights_m": [st.ground_height for st in template],
            "body_weight_n": bw,
            "height_m": height,
            "stances": [st.label for st in real],
        },
        "notes": notes,
    }
    if out_dir is not None:
        write_tables(result, out_dir)
    return result


def _check_table1(rows: list[dict]) -> None:
    cases = [r.get("case") for r in rows]
    if cases != list(TABLE1_CASES):
        raise InputError(f"Table 1 rows must be the cases {list(TABLE1_CASES)}, but got {cases}")
    for r in rows:
        keys = list(r)
        if keys[: len(TABLE1_KEYS)] != list(TABLE1_KEYS) or any(
            k not in TABLE1_KEYS and not (k.endswith("_sd") and k[:-3] in TABLE1_KEYS) for k in keys
        ):
            raise InputError(
                f"Table 1 row {r['case']!r} must have keys {list(TABLE1_KEYS)} "
                f"(+ optional '_sd' keys), but got {keys}"
            )


def table1_json(rows: list[dict]) -> str:
    _check_table1(rows)
    return json_text(rows, indent=2) + "\n"


def table2_json(table2: dict) -> str:
    return json_text(table2, indent=2) + "\n"


def _fmt(v) -> str:
    if v is None:
        return "n/a"
    return f"{v:.3g}"


def table1_markdown(rows: list[dict]) -> str:
    """Markdown of Table 1: for each case our value (mean ± sd for noisy rows) and the seed's."""
    _check_table1(rows)
    heads = ["k (% uniform k)"] + [
        f"{c.replace('_', ' ')} ({'% BW' if c.endswith('force') else '% BW*H'})" for c in CHANNELS
    ]
    lines = [
        "# Table 1: RMS errors of the stiffness fit",
        "",
        "Synthetic rows: k / 11,974 N/m, forces / 689 N, torques / 1,173 N·m (seed normalisers);",
        "experimental: the trial's BW and BW*H. Noisy rows: mean ± sd over draws.",
        "",
        "| case | source | " + " | ".join(heads) + " |",
        "|---|---|" + "---|" * len(heads),
    ]
    for r in rows:
        ours = []
        for k in TABLE1_KEYS[1:]:
            s = _fmt(r[k])
            if f"{k}_sd" in r:
                s += f" ± {_fmt(r[k + '_sd'])}"
            ours.append(s)
        seed = [_fmt(SEED_TABLE1[r["case"]][k]) for k in TABLE1_KEYS[1:]]
        lines.append(f"| {r['case']} | ours | " + " | ".join(ours) + " |")
        lines.append(f"| {r['case']} | seed | " + " | ".join(seed) + " |")
    return "\n".join(lines) + "\n"


def table2_markdown(table2: dict) -> str:
    """Markdown of Table 2: experimental k per unit per foot, ours and the seed's [N/m]."""
    lines = [
        "# Table 2: experimental stiffness k [N/m]",
        "",
        "| side | unit | ours | seed |",
        "|---|---|---|---|",
    ]
    for side in ("left", "right"):
        for u in UNITS:
            ours = table2.get(side, {}).get(u)
            lines.append(
                f"| {side} | {u} | {_fmt(ours) if ours is None else f'{ours:.2f}'} | "
                f"{SEED_TABLE2[side][u]:.2f} |"
            )
    return "\n".join(lines) + "\n"


SEED_COMMAND = "gc-ocp reproduce-seed"
"""The owner recorded in a folder of the tables (:data:`gc_ocp.outputs.OWNER`)."""

SEED_OUTPUTS: tuple[str, ...] = ("table1.json", "table1.md", "table2.json", "table2.md")
"""The files of :func:`write_tables`: one set, replaced as a whole."""


def write_tables(result: dict, out_dir: str | os.PathLike) -> dict[str, Path]:
    """Write ``table1.json``, ``table1.md``, ``table2.json``, ``table2.md`` into ``out_dir`` as
    one set (:class:`~gc_ocp.outputs.OutputSet`): written one by one, an interrupt or error
    between them left this run's Table 1 alone, or beside an earlier run's Table 2, looking like
    a result. A folder holding another command's outputs is refused."""
    # Render everything first, so a formatting error writes nothing.
    texts = {
        "table1.json": table1_json(result["table1"]),
        "table1.md": table1_markdown(result["table1"]),
        "table2.json": table2_json(result["table2"]),
        "table2.md": table2_markdown(result["table2"]),
    }
    out = OutputSet(out_dir, SEED_OUTPUTS, SEED_COMMAND)
    try:
        for name, text in texts.items():
            out.text(name, text)
        return {p.name: p for p in out.commit()}
    finally:
        out.discard()
