"""Ways to damage an OpenSim trial (TRC markers + MOT ground reactions) as real files get damaged.

Each damage is ``(kind, params)``; :func:`damage` writes damaged copies of the two files into a
folder and returns their paths. Used by ``tests/test_fuzz.py`` (a small seeded budget) and
``benchmarks/fuzz.py`` (a large one).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

KINDS = (
    "truncate_trc",
    "truncate_mot",
    "nan_run",
    "zero_run_force",
    "junk_cell",
    "scale_markers",
    "swap_axes",
    "rotate_axes",
    "shift_force_time",
    "duplicate_column",
    "drop_column",
)


def _split(text: str, marker: str) -> tuple[list[str], list[list[str]]]:
    lines = text.splitlines()
    if marker == "trc":
        head = lines[:5]
        body = [ln.split("\t") for ln in lines[5:] if ln.strip()]
        # the TRC has a blank 6th line; keep it in the header
        if len(lines) > 5 and not lines[5].strip():
            head = lines[:6]
    else:
        end = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
        head = lines[: end + 2]  # header and the column-names line
        body = [ln.split("\t") for ln in lines[end + 2 :] if ln.strip()]
    return head, body


def _join(head, body) -> str:
    return "\n".join(head + ["\t".join(r) for r in body]) + "\n"


def damage(
    trc: Path, mot: Path, kind: str, u: tuple[float, float, float], out: Path
) -> tuple[Path, Path]:
    """Damaged copies of ``trc`` and ``mot`` in ``out``; ``u``: three numbers in [0, 1) that choose
    where and how much (so that hypothesis can shrink them)."""
    th, tb = _split(trc.read_text(), "trc")
    mh, mb = _split(mot.read_text(), "mot")
    a, b, c = u
    n_t, n_m = len(tb), len(mb)
    n_markers = (len(tb[0]) - 2) // 3
    if kind == "truncate_trc":
        tb = tb[: max(1, int(n_t * (0.05 + 0.9 * a)))]
    elif kind == "truncate_mot":
        mb = mb[: max(1, int(n_m * (0.05 + 0.9 * a)))]
    elif kind == "nan_run":
        m = int(a * n_markers)
        start, length = int(b * n_t), 1 + int(c * 60)
        for r in tb[start : start + length]:
            for j in range(3):
                if 2 + 3 * m + j < len(r):
                    r[2 + 3 * m + j] = ""
    elif kind == "zero_run_force":
        start, length = int(a * n_m), 1 + int(b * 2000)
        for r in mb[start : start + length]:
            for j in (1, 2, 3, 10, 11, 12):
                if j < len(r):
                    r[j] = "0.000000"
    elif kind == "junk_cell":
        rows, bodies = (tb, "trc") if a < 0.5 else (mb, "mot")
        r = rows[int(b * len(rows))]
        r[1 + int(c * (len(r) - 1))] = "abc"
    elif kind == "scale_markers":
        f = 1000.0 if a < 0.5 else 0.001
        for r in tb:
            r[2:] = [f"{float(v) * f:.6f}" if v.strip() else v for v in r[2:]]
    elif kind == "swap_axes":
        for r in tb:
            for m in range(n_markers):
                i = 2 + 3 * m
                if i + 2 < len(r):
                    r[i + 1], r[i + 2] = r[i + 2], r[i + 1]
    elif kind == "rotate_axes":
        ang = np.pi / 2 * (1 + int(a * 3))  # 90, 180 or 270 deg about the vertical (Y in the TRC)
        cs, sn = np.cos(ang), np.sin(ang)
        for r in tb:
            for m in range(n_markers):
                i = 2 + 3 * m
                if i + 2 < len(r) and r[i].strip() and r[i + 2].strip():
                    x, z = float(r[i]), float(r[i + 2])
                    r[i], r[i + 2] = f"{cs * x - sn * z:.6f}", f"{sn * x + cs * z:.6f}"
    elif kind == "shift_force_time":
        dt = -0.3 + 0.6 * a
        for r in mb:
            r[0] = f"{float(r[0]) + dt:.6f}"
    elif kind == "duplicate_column":
        j = 1 + int(a * (len(mh[-1].split("\t")) - 1))
        names = mh[-1].split("\t")
        mh[-1] = "\t".join(names + [names[j]])
        for r in mb:
            r.append(r[j])
    elif kind == "drop_column":
        j = 1 + int(a * (len(mh[-1].split("\t")) - 1))
        names = mh[-1].split("\t")
        mh[-1] = "\t".join(names[:j] + names[j + 1 :])
        for r in mb:
            del r[j]
    else:
        raise ValueError(kind)
    out.mkdir(parents=True, exist_ok=True)
    t2, m2 = out / trc.name, out / mot.name
    t2.write_text(_join(th, tb))
    m2.write_text(_join(mh, mb))
    return t2, m2
