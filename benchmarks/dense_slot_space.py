"""Would a smaller slot space make the denser sole's per-frame Hessian cheaper? (No: measured.)

The denser sole (``contact_density``) has 80 slots per frame against the base's 36: its 16
units' points (48 numbers) and log-stiffnesses (16) are fixed linear maps of 15 nominal sole
offsets and 4 field coefficients. This script builds the per-frame Hessian of ``1/2 |res|^2``
three ways on the bundled trial's first stance and prints CasADi's SX instruction count of each
(what the compiled C runs per frame):

* as the package does: in the 80 slots;
* in the 15 offsets and 4 coefficients (the maps entered as per-frame data), 35 inputs;
* in the 15 offsets only (the maps of the points as data), 47 inputs;

and the base model's for reference.

Usage::

    PYTHONPATH=. python benchmarks/dense_slot_space.py

Output of the run cited in ``docs/diagnosis.md`` (*Speed*): ``dense_slot_space_output.txt``.
"""

from __future__ import annotations

import warnings

import casadi as ca

import gc_ocp
from gc_ocp.estimation.components import base_model
from gc_ocp.estimation.components.contact_density import ContactDensity
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.workflow.fitting import fit_data


def hessian_instructions(fm, reduce: dict[str, int]) -> tuple[int, int]:
    """``(inputs, SX instructions)`` of the per-frame Hessian when each slot named in ``reduce``
    is replaced by ``B z + b`` (``B``, ``b`` symbolic per-frame data; ``z`` of the given size)."""
    D = ca.SX.sym("D", fm.data.size)
    ny = fm.slots.size
    replaced = {i for name in reduce for i in range(*_span(fm, name))}
    kept = [i for i in range(ny) if i not in replaced]
    y_kept = ca.SX.sym("y", len(kept))
    y = ca.SX.zeros(ny)
    for j, i in enumerate(kept):
        y[i] = y_kept[j]
    inputs, data = [y_kept], [D]
    for name, r in reduce.items():
        start, stop = _span(fm, name)
        B, b, z = ca.SX.sym("B", stop - start, r), ca.SX.sym("b", stop - start), ca.SX.sym("z", r)
        inputs.insert(0, z)
        data += [ca.vec(B), b]
        v = B @ z + b
        for j in range(stop - start):
            y[start + j] = v[j]
    v = ca.vertcat(*inputs)
    H, _ = ca.hessian(0.5 * ca.sumsqr(fm.frame(D, y)[0]), v)
    return v.numel(), ca.Function("h", [*data, v], [H]).n_instructions()


def _span(fm, name: str) -> tuple[int, int]:
    start, size = fm.slots.index[name]
    return start, start + size


def main() -> None:
    warnings.simplefilter("ignore")
    trial = gc_ocp.load_trial()
    _, stances, _ = fit_data([(trial, gc_ocp.compute_kinematics(trial))])
    dense = build_estimation(stances, (*base_model(), ContactDensity()), compile=False)
    base = build_estimation(stances, base_model(), compile=False)
    fm, fb = dense.blocks[0].fm, base.blocks[0].fm
    print(f"denser sole slots: {dict((k, s) for k, (_, s) in fm.slots.index.items())}")
    for label, m, reduce in (
        ("denser sole, the package's 80 slots", fm, {}),
        ("denser sole, offsets (15) and field (4) as inputs, maps as data", fm,
         {"points_local": 15, "log_k": 4}),
        ("denser sole, offsets (15) as inputs, the points' map as data", fm, {"points_local": 15}),
        ("base model (5 units)", fb, {}),
    ):  # fmt: skip
        n, instr = hessian_instructions(m, reduce)
        print(f"{label}: {n} inputs, {instr} SX instructions")


if __name__ == "__main__":
    main()
