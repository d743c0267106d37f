"""``gc-ocp export opensim``: the calibrated contact model and the trial as OpenSim files, and
OpenSim's own contact forces compared with the package's.

Files written into the output folder (all or none, :class:`~gc_ocp.outputs.OutputSet`):

* ``model.osim``: the subject's body (the URDF the kinematics used) with one
  ``SmoothSphereHalfSpaceForce`` per contact unit (:mod:`gc_ocp.export.opensim_worker`, which
  says how the fitted law is mapped onto OpenSim's);
* ``coordinates.mot``: the coordinates over the trial, the fitted kinematics
  (:mod:`gc_ocp.export.fitted_kinematics`; radians and metres, ``inDegrees=no``);
* ``sole_points.sto``: each unit's fitted point over the trial (OpenSim's ground frame, m);
* ``grf_plates.mot`` / ``grf_model.mot``: the plates' and the calibrated model's ground
  reactions per foot in OpenSim's external-loads layout, each with its ``ExternalLoads`` file
  (``external_loads_plates.xml``, ``external_loads_model.xml``) applying them to the hindfoot
  bodies, for OpenSim's inverse dynamics or a Moco tracking problem;
* ``export.json``: the mapping of each unit's law (stiffness, dissipation, friction, transition
  velocity; how well the Hertzian curve matches the fitted one over the penetrations visited)
  and, unless ``compare_forces=False``, the RMS difference per channel between OpenSim's
  contact forces on the trial's kinematics and the package's (% BW, % BW x H), over the trial's
  stances; ``opensim_vs_gc_ocp.png`` shows both.

OpenSim runs in a separate process (its wheel's CasADi library and the ``casadi`` package
cannot share one): see :mod:`gc_ocp.export.opensim_worker`.
"""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from gc_ocp.antialias import sample_rate
from gc_ocp.contact.channels import TABLE_KEYS, channel_name, channel_rms_pct, channel_unit
from gc_ocp.errors import InputError, ModelError, require_file
from gc_ocp.export import opensim_worker as worker
from gc_ocp.export.calibrated import CalibratedContact, fit_document
from gc_ocp.export.fitted_kinematics import fitted_kinematics
from gc_ocp.export.forward import foot_wrenches
from gc_ocp.export.opensim_files import (
    LAB_TO_Y_UP,
    external_loads_xml,
    write_grf,
    write_table,
)
from gc_ocp.export.opensim_worker import DEFAULT_RADIUS
from gc_ocp.io._common import Y_UP_TO_LAB
from gc_ocp.outputs import OutputSet
from gc_ocp.stance import frame_wrench, trial_names
from gc_ocp.text import json_text
from gc_ocp.values import number
from gc_ocp.workflow.provenance import sha256
from gc_ocp.wrench import transport_wrench

MAX_RADIUS = 0.05
"""[m] The largest contact sphere the export takes: a heel's curvature (5 cm); a unit's sphere is
millimetres (the default 5 mm), and a radius in metres given as millimetres (5) made a
200 million % BW misfit."""

OUTPUTS = (
    "model.osim",
    "coordinates.mot",
    "sole_points.sto",
    "grf_plates.mot",
    "grf_model.mot",
    "external_loads_plates.xml",
    "external_loads_model.xml",
    "export.json",
    "opensim_vs_gc_ocp.png",
)
"""Every file the OpenSim export may write (one set, replaced as a whole)."""

HINDFOOT = {"left": "hindfoot_l", "right": "hindfoot_r"}
HERTZ_EXPONENT = 1.5
"""The penetration exponent of OpenSim's ``SmoothSphereHalfSpaceForce`` (Hertz's sphere)."""
"""The body each foot's ground reaction is applied to."""


# --- the law, mapped ---------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class UnitMapping:
    """One unit's OpenSim parameters and how well its Hertzian curve matches the fitted law
    over the penetrations the unit visited: ``curve_rms_pct`` (RMS of the difference over the
    fitted force's RMS, visited frames), ``frames`` visited, ``max_depth_mm``."""

    sphere: worker.SphereUnit
    curve_rms_pct: float
    frames: int
    max_depth_mm: float

    def to_json(self) -> dict:
        s = self.sphere
        return {
            "side": s.side,
            "unit": s.unit,
            "body": s.body,
            "sphere_centre_m": [float(v) for v in s.location],
            "stiffness": s.stiffness,
            "dissipation": s.dissipation,
            "dynamic_friction": s.friction,
            "static_friction": s.static_friction,
            "transition_velocity": s.transition_velocity,
            "curve_rms_pct": self.curve_rms_pct,
            "frames_in_contact": self.frames,
            "max_depth_mm": self.max_depth_mm,
        }


def fit_friction(v: np.ndarray, w: np.ndarray, eps: float) -> tuple[float, float]:
    """``(v_t, s)``: OpenSim's friction ramp ``min(r, 1) (1 + 2 (s - 1) / (1 + r^2))``,
    ``r = v / v_t`` (static friction ``s`` times the dynamic one) that best matches the fitted
    friction's ``v / sqrt(v^2 + eps^2)`` over the slip speeds ``v``, weighted by the force ``w``
    (grid search). With ``s < 1`` the ramp bends as the fitted law does: on a uniform grid of
    speeds its RMS difference is 0.038 of the friction force against 0.048 with ``s = 1``."""
    target = v / np.sqrt(v * v + eps * eps)
    best = (np.inf, eps, 1.0)
    for vt in np.geomspace(eps / 20, eps * 20, 200):
        r = v / vt
        ramp = np.minimum(r, 1.0)
        bend = 2.0 / (1.0 + r * r)
        for s in np.linspace(0.2, 1.2, 51):
            cost = float(np.sum(w * (ramp * (1.0 + (s - 1.0) * bend) - target) ** 2))
            if cost < best[0]:
                best = (cost, float(vt), float(s))
    return best[1], best[2]


def map_law(
    cal: CalibratedContact, trial, kin, radius: float = DEFAULT_RADIUS
) -> list[UnitMapping]:
    """Each unit's ``SmoothSphereHalfSpaceForce`` parameters (module doc of
    :mod:`~gc_ocp.export.opensim_worker`): the Hertzian stiffness fitted in least squares to
    ``k d^n`` over the penetrations ``d`` the unit visits on the stances of ``trial`` (the frames
    the fit was calibrated on; at the reference depth when it never touches), the dissipation
    ``c / 1.5``, the friction coefficient, and the transition velocity and static friction
    fitted to the fitted friction's smoothing over the slip speeds visited (:func:`fit_friction`). The sphere's
    centre is ``R`` above the unit's point along the floor's normal as the segment meets the
    floor (its mean direction in the segment over the stances): the segment's own axes need not
    be square to the sole (the hindfoot is pitched about 25-30 deg in stance on the bundled
    trial), and a centre on the segment's Z axis would press ``R (1 - cos 27 deg)`` deeper,
    +12 % force at 5 mm radius."""
    kin = cal.feet(kin)
    eps = cal.law.slip_smoothing
    out = []
    for side in sorted(kin.feet):
        foot = kin.feet[side]
        pos, vel = foot.unit_trajectories(np.asarray(cal.points[side]))
        belt = cal.belt_velocity
        n, c, mu = (cal.value(p, side) for p in ("n", "c", "mu"))
        stance = np.zeros(foot.time.size, bool)
        for st_side, idx, _ in _stance_frames(trial, foot.time):
            if st_side == side:
                stance[idx] = True
        up = {}  # the floor's normal in each segment's frame, as the foot stands on the floor
        for seg, pose in (("hindfoot", foot.hindfoot_pose), ("toes", foot.toes_pose)):
            rows = pose[stance if stance.any() else slice(None), 2, :3]
            u = np.nanmean(rows, axis=0)
            up[seg] = u / np.linalg.norm(u)
        for i, unit in enumerate(cal.units):
            k = cal.value("k", side, unit)
            d = cal.ground_height - pos[:, i, 2]
            on = stance & np.isfinite(d) & (d > 0)
            if on.sum() >= 3:
                dd = d[on]
                K = float(np.sum(k * dd**n * dd**1.5) / np.sum(dd**3))
                f = k * dd**n
                rms = float(100 * np.sqrt(np.mean((K * dd**1.5 - f) ** 2)) / np.sqrt(np.mean(f**2)))
                slip = np.linalg.norm((vel[on, i] - belt)[:, :2], axis=1)
                vt, s_static = fit_friction(slip, f, eps)
            else:
                K = k * cal.law.reference_depth ** (n - 1.5)
                rms, vt, s_static, dd = float("nan"), eps, 1.0, np.zeros(1)
            parent = cal.parents[side][i]
            out.append(
                UnitMapping(
                    worker.SphereUnit(
                        side=side,
                        unit=unit,
                        body=f"{parent}_{side[0]}",
                        location=np.asarray(cal.points[side][i], float) + radius * up[parent],
                        stiffness=K / (worker.HERTZ_GAIN * np.sqrt(radius)),
                        dissipation=c / 1.5,
                        friction=mu,
                        static_friction=s_static * mu,
                        transition_velocity=vt,
                    ),
                    rms,
                    int(on.sum()),
                    float(1e3 * dd.max()),
                )
            )
    return out


# --- OpenSim, in its own process ---------------------------------------------------------


def run_worker(job: dict) -> dict:
    """Run :mod:`~gc_ocp.export.opensim_worker` on ``job`` in a fresh Python process (module
    doc) and return its reply; its failure is a :class:`ModelError` with OpenSim's message."""
    with tempfile.TemporaryDirectory(prefix="gc_ocp_opensim_") as tmp:
        path = Path(tmp) / "job.json"
        path.write_text(json.dumps(job))
        proc = subprocess.run(
            [sys.executable, "-I", worker.__file__, str(path)], capture_output=True, text=True
        )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    reply = json.loads(lines[-1]) if lines else {}
    if proc.returncode != 0 or "error" in reply:
        why = (
            reply.get("error")
            or proc.stderr.strip().splitlines()[-1:]
            or [f"no message; the OpenSim process ended with status {proc.returncode}"]
        )
        raise ModelError(f"OpenSim could not carry out the export: {why}")
    return reply


def _sphere_json(s: worker.SphereUnit) -> dict:
    d = dataclasses.asdict(s)
    d["location"] = [float(v) for v in s.location]
    return d


OSIM_NAME_FORBIDDEN = re.compile(r"[\\*+/\s]")
"""Characters OpenSim refuses in a component's name (its ``InvalidComponentName``: back and
forward slash, '*', '+', white space); a model named after a trial file 'walk 01.c3d' crashed
the worker."""


def osim_name(name: str) -> str:
    """``name`` as an OpenSim component may be named: each character OpenSim refuses
    (:data:`OSIM_NAME_FORBIDDEN`) replaced by '_'."""
    return OSIM_NAME_FORBIDDEN.sub("_", name)


def model_job(cal: CalibratedContact, kin, spheres, radius: float, name: str, model=None) -> dict:
    """The worker's job that builds the OpenSim model: the package's body (the URDF ``kin``
    was computed with, with its registered markers) or the user's ``model`` file, and the
    ``spheres`` on the floor; ``name``: the model's (:func:`osim_name` of it)."""
    return {
        "urdf": kin.info["body"].urdf,
        "model": None if model is None else str(Path(model).resolve()),
        "name": osim_name(name),
        "floor_height": cal.ground_height,
        "radius": radius,
        "spheres": [_sphere_json(s) for s in spheres],
        "markers": _marker_set(kin),
    }


def opensim_forces(job: dict, kin, mapping: Sequence[UnitMapping]) -> dict[str, np.ndarray]:
    """OpenSim's contact wrench on each foot over the frames of ``kin`` (``{side: (n, 6)}``,
    force [N] and moment [N m] about the ``lab`` origin, in ``lab``), computed by OpenSim from
    the coordinates ``kin.q`` and their rates on the model of ``job`` (:func:`model_job`; in
    the same worker process that writes the model, when the job names an ``osim`` file)."""
    q = np.asarray(kin.q, float)
    qdot = np.gradient(q, kin.time, axis=0)
    with tempfile.TemporaryDirectory(prefix="gc_ocp_opensim_") as tmp:
        frames, out = Path(tmp) / "frames.npz", Path(tmp) / "forces.npz"
        np.savez(frames, coordinates=np.array(kin.info["body"].joint_names), q=q, qdot=qdot)
        run_worker({**job, "forces": {"frames": str(frames), "out": str(out)}})
        with np.load(out) as per_sphere:
            forces = {k: per_sphere[k] for k in per_sphere.files}
    total = {side: np.zeros((q.shape[0], 6)) for side in kin.feet}
    for m in mapping:
        w = forces[m.sphere.name]
        total[m.sphere.side] += np.c_[w[:, :3] @ Y_UP_TO_LAB.T, w[:, 3:] @ Y_UP_TO_LAB.T]
    return total


# --- a user's own model ------------------------------------------------------------------

REGISTRATION_LIMIT_MM = 10.0
"""[mm] Largest RMS residual of the markers' rigid fit between the package's foot and the user's
foot body: beyond it the two do not describe the same foot (another subject, scaling, or
markers placed elsewhere) and the spheres would land off the sole."""


def osim_markers(path: Path) -> dict[str, tuple[str, np.ndarray]]:
    """``{marker: (body, location in the body)}`` of an ``.osim`` file's marker set (OpenSim 4:
    ``socket_parent_frame`` ``/bodyset/<body>``; OpenSim 3: ``<body>``)."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise InputError(
            f"{path} is not a readable OpenSim model ({e}); give a .osim file."
        ) from None
    out = {}
    for m in root.iter("Marker"):
        frame = m.findtext("socket_parent_frame") or m.findtext("body") or ""
        parts = [p for p in frame.strip().split("/") if p]
        if parts[:1] == ["bodyset"]:
            parts = parts[1:]
        loc = m.findtext("location")
        if len(parts) != 1 or loc is None:
            continue  # on an offset frame or without a location: not used
        out[m.get("name")] = (parts[0], np.array([float(v) for v in loc.split()], float))
    return out


def register_feet(path: Path, kin, mapping: Sequence[UnitMapping]) -> tuple[list, dict]:
    """The units of ``mapping`` moved onto the user's model at ``path``: for each foot, the
    user's body that holds the most of the foot markers both models share (at least three),
    and the rigid transform from the package's hindfoot frame to it, fitted to those markers
    (Kabsch). Returns the spheres on the user's bodies and, per side, the body, the markers and
    the fit's RMS residual [mm]. A foot the markers cannot place is an :class:`InputError`."""
    from gc_ocp.geometry import kabsch

    theirs = osim_markers(path)
    mm = kin.info.get("marker_model")
    if mm is None:
        raise InputError("the kinematics carry no marker model; compute them with gc_ocp")
    spheres, report = [], {}
    for side, foot in sorted(kin.feet.items()):
        suffix = side[0]
        k = int(np.argmax(np.isfinite(foot.hindfoot_pose).all(axis=(1, 2))))  # a posed frame
        to_hind = np.linalg.inv(foot.hindfoot_pose[k]) @ foot.toes_pose[k]  # welded: constant
        ours = {}  # by the names the exported models give them (osim_name)
        for label, seg, loc in zip(mm.names, mm.segments, mm.local, strict=True):
            name = osim_name(label)
            if seg == f"hindfoot_{suffix}":
                ours[name] = np.asarray(loc, float)
            elif seg == f"toes_{suffix}":
                ours[name] = to_hind[:3, :3] @ loc + to_hind[:3, 3]
        shared = [n for n in ours if n in theirs]
        by_body: dict[str, list[str]] = {}
        for n in shared:
            by_body.setdefault(theirs[n][0], []).append(n)
        body, names = max(by_body.items(), key=lambda kv: len(kv[1]), default=(None, []))
        if len(names) < 3:
            raise InputError(
                f"{path}: the {side} foot cannot be placed on the model: it shares "
                f"{len(names)} foot markers on one body ({names or 'none'}) with the trial's "
                f"foot markers {sorted(ours)}; at least three are needed. Name the model's "
                "foot markers as the trial's, or export without --model."
            )
        a = np.array([ours[n] for n in names])
        b = np.array([theirs[n][1] for n in names])
        R, t = kabsch(a, b)
        rms = float(1e3 * np.sqrt(np.mean(np.sum((a @ R.T + t - b) ** 2, axis=1))))
        if rms > REGISTRATION_LIMIT_MM:
            raise InputError(
                f"{path}: the {side} foot markers {names} do not fit the model's {body} as one "
                f"rigid foot (RMS {rms:.1f} mm > {REGISTRATION_LIMIT_MM:.0f} mm): another "
                "subject, another scaling or markers placed elsewhere. Scale the model to this "
                "subject, or export without --model."
            )
        report[side] = {"body": body, "markers": names, "rms_mm": rms}
        for m in mapping:
            sp = m.sphere
            if sp.side != side:
                continue
            c = np.asarray(sp.location, float)
            if sp.body.startswith("toes"):
                c = to_hind[:3, :3] @ c + to_hind[:3, 3]
            spheres.append(dataclasses.replace(sp, body=body, location=R @ c + t))
    return spheres, report


def _marker_set(kin) -> list[dict]:
    """The registered markers (the kinematics' marker model) for the exported body."""
    mm = kin.info.get("marker_model")
    if mm is None:
        return []
    return [  # named as OpenSim may name them (a label 'L HEE' crashed OpenSim)
        {"name": osim_name(n), "body": seg, "location": [float(v) for v in loc]}
        for n, seg, loc in zip(mm.names, mm.segments, mm.local, strict=True)
    ]


# --- the comparison ----------------------------------------------------------------------


def _stance_frames(trial, time):
    """``[(side, frame indices, reference point)]`` of the trial's stances."""
    out = []
    for st in trial.stances:
        idx = np.flatnonzero((time >= st.t_on - 1e-9) & (time <= st.t_off + 1e-9))
        if idx.size:
            out.append((st.side, idx, np.asarray(st.reference_point, float)))
    return out


def compare(trial, time, ours: dict, theirs: dict, cal: CalibratedContact) -> dict:
    """RMS of OpenSim's minus the package's wrench per channel over the trial's stances, each
    stance's moments about its reference point (as every fit reports them): ``{"all": {channel:
    value}, side: {...}}`` in % BW and % BW x H, keyed as ``fit.json``'s ``rms``
    (``superior_force_pct_bw``)."""
    a, b, sides = [], [], []
    for side, idx, ref in _stance_frames(trial, time):
        if side not in ours:  # a foot the fit has no contact of
            continue
        for w, acc in ((ours[side][idx], a), (theirs[side][idx], b)):
            acc.append(transport_wrench(w, np.zeros(3), ref))
        sides += [side] * idx.size
    if not a:
        raise InputError(f"{trial.source}: no stance to compare the forces on")
    a, b, sides = np.concatenate(a), np.concatenate(b), np.asarray(sides)
    ok = np.isfinite(a).all(axis=1) & np.isfinite(b).all(axis=1)
    bwh = cal.body_weight * cal.height

    def rms(sel):  # keyed as fit.json's rms ("superior_force_pct_bw")
        return {
            TABLE_KEYS[c]: v
            for c, v in channel_rms_pct(a[sel], b[sel], cal.body_weight, bwh).items()
        }

    out = {"all": rms(ok)}
    for side in ("left", "right"):
        sel = ok & (sides == side)
        if sel.any():
            out[side] = rms(sel)
    return out


def plot_comparison(
    time, ours: dict, theirs: dict, plates: dict, cal: CalibratedContact, stances=()
):
    """Figure: the vertical and anterior force of each foot [% BW]: the plates, the package's
    model and OpenSim's; ``stances``: ``[(side, t_on, t_off)]`` of the trial's stances on a
    plate, shaded (the frames the RMS compares; elsewhere no plate measures the foot, and the
    model's force there, hundreds of % BW on the bundled trial's ends, is checked by none). A
    :class:`~matplotlib.figure.Figure`, not pyplot's: it was left open in pyplot, shown by a
    notebook after every export and kept to the end of a script."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    fig = Figure(figsize=(10, 6), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    for j, side in enumerate(("left", "right")):
        for i, (col, what) in enumerate(((2, "vertical"), (0, "anterior"))):
            ax = axes[i, j]
            for s, t_on, t_off in stances:
                if s == side:
                    ax.axvspan(t_on, t_off, color="C2", alpha=0.12, lw=0)
            if side in plates:
                ax.plot(
                    time,
                    100 * plates[side][:, col] / cal.body_weight,
                    color="0.6",
                    lw=3,
                    label="plates",
                )
            if side in ours:
                ax.plot(
                    time,
                    100 * ours[side][:, col] / cal.body_weight,
                    color="C0",
                    label="gc_ocp model",
                )
            if side in theirs:
                ax.plot(
                    time,
                    100 * theirs[side][:, col] / cal.body_weight,
                    "--",
                    color="C3",
                    label="OpenSim (SmoothSphereHalfSpaceForce)",
                )
            ax.set_title(f"{side}: {what} force")
            ax.set_ylabel("% BW")
    handles, _ = axes[0, 0].get_legend_handles_labels()
    if stances:
        handles.append(
            Patch(
                color="C2", alpha=0.12, label="stance on a plate (compared; elsewhere unmeasured)"
            )
        )
    axes[0, 0].legend(handles=handles, fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    return fig


# --- the export --------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class OpenSimExport:
    """What :func:`export_opensim` wrote and measured: ``files``; ``mapping`` (per unit);
    ``rms``: OpenSim against the package per channel (None without the comparison)."""

    files: list[Path]
    mapping: list[UnitMapping]
    rms: dict | None
    notes: tuple[str, ...] = ()

    def summary(self) -> str:
        lines = [f"wrote {len(self.files)} files to {self.files[0].parent}"]
        if self.rms is not None:
            lines.append(
                "OpenSim's contact forces against gc_ocp's on the trial's stances (RMS): "
                + ", ".join(
                    f"{channel_name(k)} {v:.2f} {channel_unit(k).replace('×', ' x ')}"
                    for k, v in self.rms["all"].items()
                )
            )
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


def plate_wrenches(trial, time) -> dict[str, np.ndarray]:
    """The plates' wrench per foot over the frames ``time`` (about the ``lab`` origin; zero off
    the stances), low-passed for the frames' rate as a fit reads them."""
    out = {s: np.zeros((time.size, 6)) for s in ("left", "right")}
    rate = sample_rate(time) if time.size > 1 else None
    for st in trial.stances:
        sel = (time >= st.t_on) & (time <= st.t_off)
        if not sel.any():
            continue
        w = frame_wrench(trial, st, time[sel], rate)  # as the fit reads them
        out[st.side][sel] = transport_wrench(w, st.reference_point, np.zeros(3))
    return out


def model_wrenches(cal: CalibratedContact, trial, kin) -> dict[str, np.ndarray]:
    """The calibrated model's wrench per foot on every frame of ``kin`` (about the ``lab``
    origin), on the fit's belt: a treadmill trial loaded again has no belt speed until a fit's
    checks find it, and friction against the foot's speed over the ground instead of over the
    belt would be a different model (tens of % BW of anterior force)."""
    on_belt = dataclasses.replace(trial, belt_velocity=cal.belt_velocity)
    return foot_wrenches(cal.model(), on_belt, kin, cal.ground_height).wrench


def check_request(fit, model: str | Path | None = None, trial: str | None = None) -> None:
    """An ``--model`` file that is not there, or a ``--trial`` the fit does not have, as an
    :class:`InputError` before any work (the trials' kinematics, a ``--hertz`` refit)."""
    if model is not None:  # a folder named as a folder (require_file)
        require_file(model, "Model", "give the subject's .osim file (--model).")
    if trial is not None:
        names = list(dict.fromkeys(sf["trial"] for sf in fit_document(fit)["stance_fits"]))
        if trial not in names:
            raise InputError(
                f"the fit has no trial {trial!r} to export; its trials are {names} (--trial NAME)"
            )


def export_opensim(
    fit,
    out: str | Path,
    pairs: Sequence | None = None,
    radius: float = DEFAULT_RADIUS,
    compare_forces: bool = True,
    fitted: bool = True,
    model: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
    trial: str | None = None,
) -> OpenSimExport:
    """Write the OpenSim files of ``fit`` (module doc) into ``out``.

    fit: a ``FitReport``, an ``EstimationResult``, a ``fit.json`` dict or its path; pairs: the
    fit's ``[(Trial, TrialKinematics)]`` (default: loaded again from the fit's provenance, as
    the fit loaded them; the first trial is exported); radius: the contact spheres' [m];
    compare_forces: also compute the contact forces with OpenSim on the trial and compare;
    fitted: the coordinates are the fitted kinematics (each stance's foot where the fit's pose
    correction put it, :mod:`gc_ocp.export.fitted_kinematics`), else the inverse kinematics;
    model: the user's own ``.osim``: the spheres are attached to its foot bodies, placed by the
    foot markers it shares with the trial (:func:`register_feet`), and written into a copy of it
    as ``model.osim``; the coordinates and the comparison (which need the package's body) are
    then not written; trial: the fit's name of the trial exported (a fit of several trials:
    each has its own kinematics and unit points; default the first)."""
    say = progress or (lambda s: None)
    radius = number(radius, "radius", "m")
    if not 0.0 < radius <= MAX_RADIUS:
        raise InputError(
            f"radius {radius:g} m is not a contact sphere's under a foot (0 to {MAX_RADIUS:g} m; "
            f"default {DEFAULT_RADIUS:g} m): give it in metres (--radius 0.005)"
        )
    doc = fit_document(fit)
    check_request(doc, model, trial)  # before the trials are loaded again
    if pairs is None:
        pairs = fit_pairs(CalibratedContact.from_fit(doc), say)
    # the fit's name of the exported trial: several trials of one subject each have their own
    # kinematics (their points, their stances)
    names = trial_names([t.source for t, _ in pairs])
    if trial is not None and trial not in names:
        raise InputError(
            f"the fit has no trial {trial!r} to export; its trials are {names} (--trial NAME)"
        )
    pick = 0 if trial is None else names.index(trial)
    (trial, ik), name = pairs[pick], names[pick]
    body = ik.info.get("body")
    if body is None:
        raise InputError("the kinematics carry no body model; compute them with gc_ocp")
    cal = CalibratedContact.from_fit(doc, trial=name)
    fk = fitted_kinematics(doc, ik, cal.points, name)
    kin = fk.kin if fitted else ik
    feet = cal.feet(kin)
    mapping = map_law(cal, trial, kin, radius)
    spheres, registration, loaded = [m.sphere for m in mapping], None, dict(HINDFOOT)
    if model is not None:  # there: check_request
        model = Path(model)
        spheres, registration = register_feet(model, kin, mapping)
        loaded = {side: r["body"] for side, r in registration.items()}
        compare_forces = False
    outset = OutputSet(out, OUTPUTS, "gc-ocp export")
    try:
        job = model_job(cal, kin, spheres, radius, f"gc_ocp_{trial.name}", model)
        job["osim"] = str(outset.path("model.osim"))
        theirs = None
        if compare_forces:  # one OpenSim process builds, writes and runs the model
            say("OpenSim: the model, and its contact forces on the trial's kinematics")
            theirs = opensim_forces(job, kin, mapping)
        else:
            say("OpenSim: building the model")
            run_worker(job)
        time = np.asarray(kin.time, float)
        if model is None:  # the package's body: its coordinates
            write_table(
                outset.path("coordinates.mot"),
                ["time", *body.joint_names],
                np.c_[time, kin.q],
                "coordinates",
            )
        cols, blocks = ["time"], [time[:, None]]
        for side, foot in sorted(feet.feet.items()):
            pos, _ = foot.unit_trajectories(np.asarray(cal.points[side]))
            for i, u in enumerate(cal.units):
                cols += [f"{side}_{u}_{a}" for a in "xyz"]
                blocks.append(pos[:, i] @ LAB_TO_Y_UP.T)
        write_table(
            outset.path("sole_points.sto"), cols, np.concatenate(blocks, axis=1), "sole_points"
        )
        ours = model_wrenches(cal, trial, feet)
        plates = plate_wrenches(trial, time)
        for name, w in (("plates", plates), ("model", ours)):
            grf = outset.path(f"grf_{name}.mot")
            write_grf(grf, time, {s: np.nan_to_num(v) for s, v in w.items()}, cal.ground_height)
            outset.text(
                f"external_loads_{name}.xml",
                external_loads_xml(grf, {s: loaded[s] for s in w}, f"ground_reactions_{name}"),
            )
        rms = None
        if theirs is not None:
            rms = compare(trial, time, ours, theirs, cal)
            spans = [(st.side, st.t_on, st.t_off) for st in trial.stances]
            fig = plot_comparison(time, ours, theirs, plates, cal, spans)
            outset.figure("opensim_vs_gc_ocp.png", fig)
        notes = _notes(cal, doc)
        notes += [
            f"the fit has no {side} stance: the {side} foot has no contact spheres and no "
            "model forces (its plates' forces are written)"
            for side in sorted(kin.feet)
            if side not in cal.points
        ]
        export_doc = {
            "trial": str(trial.source),
            "radius_m": radius,
            "force": "SmoothSphereHalfSpaceForce",
            "floor_height_m": cal.ground_height,
            "belt_speed_m_s": cal.belt_speed,
            "units": [m.to_json() for m in mapping],
            "kinematics": {
                "source": "fitted (inverse kinematics, each fitted stance's foot, the held-out "
                "one's too, moved by the fit's pose correction; gc_ocp.export.fitted_kinematics)"
                if fitted
                else "inverse kinematics",
                "frames_corrected": dict(fk.frames) if fitted else {},
                "foot_placement_residual_mm": fk.residual_mm if fitted else 0.0,
                "foot_placement_residual_deg": fk.residual_deg if fitted else 0.0,
            },
            "opensim_vs_gc_ocp_rms": rms,
            "user_model": None
            if model is None
            else {
                "file": str(model),
                "feet": registration,
                "note": "every unit is on the body the foot markers place (the toe tip too: "
                "a model with a toe joint gets its toe-tip sphere on the hindfoot); the "
                "ground reactions are in the trial's lab frame, which is the model's ground "
                "when the trial's files are the ones the model was fitted to",
            },
            "notes": notes,
        }
        outset.text("export.json", json_text(export_doc, indent=2))
        files = outset.commit()
    finally:
        outset.discard()
    return OpenSimExport(files, mapping, rms, tuple(notes))


def _notes(cal: CalibratedContact, doc: Mapping | None = None) -> list[str]:
    notes = []
    if doc is not None and doc.get("heldout_stance") and not doc.get("heldout"):
        notes.append(
            f"the held-out stance {doc['heldout_stance']} keeps its inverse-kinematics pose: "
            "this fit.json (from gc_ocp before 2026-11-30) has no pose correction of it, and "
            "the model's forces there are not the held-out fit's; refit to export it corrected"
        )
    if cal.belt_speed > 0:
        notes.append(
            f"treadmill ({cal.belt_speed:.2f} m/s): OpenSim's half space does not move, so its "
            "friction acts on the foot's speed over the ground, not over the belt; the "
            "comparison's shear forces show the difference"
        )
    n = {cal.value("n", side) for side in cal.points}
    if any(abs(v - HERTZ_EXPONENT) > 1e-9 for v in n):
        notes.append(
            f"the fitted exponent n = {', '.join(f'{v:.3g}' for v in sorted(n))} is not OpenSim's "
            f"Hertzian {HERTZ_EXPONENT}: each sphere's stiffness matches the fitted law only on "
            "average over its stances' depths, so the forces differ; gc-ocp export opensim "
            f"--hertz (hertz_refit) refits with n = {HERTZ_EXPONENT} first"
        )
    return notes


def hertz_refit(
    pairs: Sequence,
    progress: Callable[[str], None] | None = None,
    bias_correction: int | None = None,
):
    """The default model refitted to ``pairs`` with the penetration exponent fixed at
    OpenSim's Hertzian 1.5 (a ``FitReport``; no held-out stance): exported, OpenSim's law is
    the fitted law and only the sphere's geometry and the smoothings differ. Its in-sample RMS
    against the free exponent's is the price, in the fit's own terms. ``bias_correction``: as
    the exported fit's (its provenance's option; None: as :func:`~gc_ocp.workflow.fitting.fit`
    decides)."""
    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.components.contact import Param
    from gc_ocp.workflow.fitting import fit

    model = full_model()
    model = tuple(
        dataclasses.replace(c, n=Param("fixed", HERTZ_EXPONENT)) if c.name == "contact" else c
        for c in model
    )
    return fit(
        list(pairs), model=model, holdout=None, progress=progress, bias_correction=bias_correction
    )


def fit_pairs(cal: CalibratedContact, say=lambda s: None) -> list:
    """The fit's trials and kinematics, loaded again from its provenance (files, mass, height,
    belt speed, static trial, marker set, cutoff and foot roll as the fit used them)."""
    from gc_ocp.batch.manifest import Subject, TrialSpec
    from gc_ocp.batch.subject import load_subject

    prov = cal.provenance
    trials = prov.get("trials") or []
    if not trials:
        raise InputError(
            "the fit.json has no provenance of its trials; give the trials in Python "
            "(export_opensim(fit, out, pairs=[(trial, kinematics)]))."
        )
    opts = prov.get("options") or {}
    specs = []
    for t in trials:
        files = [Path(f["path"]) for f in t.get("files", [])]
        missing = [str(f) for f in files if not f.is_file()]
        if missing:
            raise InputError(
                f"the fit's trial files {missing} are gone; export where the fit ran, or give "
                "the trials in Python (pairs=...)."
            )
        changed = [
            f["path"]
            for f in t.get("files", [])
            if f.get("sha256") and sha256(Path(f["path"])) != f["sha256"]
        ]
        if changed:  # the fit's contact model on another recording's kinematics
            raise InputError(
                f"the fit's trial files {changed} have changed since the fit (their SHA-256 is "
                "not the one fit.json records): fit them again, or give the trials in Python "
                "(pairs=...)."
            )
        specs.append(TrialSpec(files[0], files[1] if len(files) > 1 else None))
    static = opts.get("static")
    subject = Subject(
        id="export",
        trials=tuple(specs),
        static=None if static is None else Path(static),
        mass=trials[0].get("mass_kg"),
        height=trials[0].get("height_m"),
        belt_speed=opts.get("belt_speed"),
        markerset=opts.get("markerset"),
        cutoff=opts.get("cutoff"),
        # a foot with two landmarks is levelled or posed by the chain as the fit's was
        foot_roll=opts.get("foot_roll") or "chain",
    )
    say("loading the fit's trials and computing their kinematics")
    with tempfile.TemporaryDirectory(prefix="gc_ocp_export_") as tmp:
        return load_subject(subject, Path(tmp), strict=True)[0]  # the fit used each


__all__ = (
    "DEFAULT_RADIUS",
    "OUTPUTS",
    "OpenSimExport",
    "UnitMapping",
    "compare",
    "export_opensim",
    "fit_pairs",
    "hertz_refit",
    "map_law",
    "model_job",
    "model_wrenches",
    "opensim_forces",
    "plate_wrenches",
)
