"""Command-line interface."""

from __future__ import annotations

import json

from gc_ocp.cli import main
from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS
from gc_ocp.sole import UNITS

TABLE1_CASES = [
    "synthetic_noiseless_uniform_k",
    "synthetic_noiseless_random_k",
    "synthetic_noisy_uniform_k",
    "synthetic_noisy_random_k",
    "experimental",
]
TABLE1_KEYS = ["case", "k_rms_pct", *(TABLE_KEYS[c] for c in CHANNELS)]


def test_reproduce_seed_cli(tmp_path, capsys):
    out = tmp_path / "seed"
    assert main(["reproduce-seed", "--seeds", "2", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "Table 1" in captured.out and "Table 2" in captured.out
    assert "[1/" in captured.err  # progress goes to stderr

    rows = json.loads((out / "table1.json").read_text())
    assert [r["case"] for r in rows] == TABLE1_CASES
    for r in rows:
        noisy = "noisy" in r["case"]
        expected = TABLE1_KEYS + ([f"{k}_sd" for k in TABLE1_KEYS[1:]] if noisy else [])
        assert list(r) == expected, r["case"]
    assert rows[-1]["k_rms_pct"] is None
    assert all(isinstance(r["k_rms_pct"], float) for r in rows[:-1])
    assert rows[0]["k_rms_pct"] < 1e-6  # noiseless synthetic data are recovered exactly

    t2 = json.loads((out / "table2.json").read_text())
    assert sorted(t2) == ["left", "right"]
    for side in ("left", "right"):
        assert list(t2[side]) == list(UNITS) == ["PL", "PM", "AL", "AM", "TT"]
        assert all(isinstance(v, float) for v in t2[side].values())
    for name in ("table1.md", "table2.md"):
        assert (out / name).read_text().startswith("# Table")
