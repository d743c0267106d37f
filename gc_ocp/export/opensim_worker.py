"""The calibrated contact model as an OpenSim model (``.osim``): the package's body (the URDF
the kinematics were computed with) and one ``SmoothSphereHalfSpaceForce`` per contact unit.

**A script of its own.** The ``opensim`` wheel carries its own CasADi library (3.7, for Moco),
which cannot share a process with the ``casadi`` package gc_ocp uses (3.8: undefined symbols on
import, whichever comes first). Everything that needs OpenSim therefore runs here, in a
separate Python process started by :mod:`gc_ocp.export.opensim`, and this file imports nothing
of gc_ocp (NumPy, SciPy and ``opensim`` only): ``python opensim_worker.py JOB.json`` reads a
job (the URDF, the spheres, where to write the model; optionally frames of coordinates on which
OpenSim computes the contact forces, and an inverse dynamics to run) and prints a JSON reply.

**The body.** Every URDF link with mass becomes a ``Body`` (mass, centre of mass, inertia about
it). The URDF builds a joint of several axes as a chain of one-axis joints through massless
links (the pelvis's six, a hip's three, the ankle's two); OpenSim refuses massless bodies, so
each chain becomes one ``CustomJoint`` named after its body, whose coordinates keep the URDF
joints' names, axes and limits (revolute joints: successive rotations about their axes, as the
chain turns; prismatic: translations in the parent frame); a ``fixed`` joint between bodies is
a ``WeldJoint``. The unit frames are not bodies: the units are contact spheres on the hindfoot
and toes. OpenSim's ground is Y up: the first joint hangs from a frame of the ground turned by
:data:`~gc_ocp.export.opensim_files.LAB_TO_Y_UP`, so the coordinates keep their meaning (the
package's ``q`` is the model's state, radians and metres) and the bodies their own frames.

**The contact.** Each unit is a ``ContactSphere`` of radius ``R`` on its segment whose lowest
point, with the foot level, is the unit's fitted point; the floor a ``ContactHalfSpace`` at the
trial's floor height. OpenSim's smooth Hunt-Crossley law (Simbody's
``SmoothSphereHalfSpaceForce``) is Hertzian, ``F = K d^1.5 (1 + 1.5 c' d')`` with
``K = (4/3) 2^-1.5 E sqrt(R)``, and its friction ``F min(r, 1) (mu_d + 2 (mu_s - mu_d) / (1 + r^2))``, ``r = v / v_t``. The fitted law ``F = k d^n (1 + c d')`` is mapped onto it
(:func:`map_law`): ``c' = c / 1.5`` (the same damping factor), the dynamic friction ``mu`` as fitted, and per
unit the ``K`` that best matches ``k d^n`` in least squares over the penetrations the unit
visited on the trial's stances (exact when ``n = 1.5``), ``v_t`` and ``mu_s`` likewise against
the fitted friction's smoothing over the slip speeds visited (``gc_ocp.export.opensim_export``). What remains is the sphere's geometry (with the foot tilted by
``a`` its lowest point is ``R (1 - cos a)`` below the unit's; a small radius keeps that small)
and the laws' smoothings; :func:`compare_forces` measures it with OpenSim itself.

``HuntCrossleyForce`` (Simbody's original) has the same Hertzian elastic law and a Stribeck
friction that is not differentiable at the contact's onset; it cannot fit the law better and
direct collocation (Moco, PredSim) needs the smooth one, so the smooth force is what is
written.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation


class ModelError(Exception):
    """A model this script cannot build (reported to the calling process)."""


DEFAULT_RADIUS = 0.005
"""[m] Contact sphere radius: small, so that a tilted foot's sphere touches where the unit is
(``R (1 - cos 30 deg)`` = 0.7 mm at 30 deg of foot pitch)."""
HERTZ_SMOOTHING = 2000.0
"""[1/m] OpenSim's ``hertz_smoothing`` (tanh of ``b d``: the force switches on over ~1/b =
0.5 mm of penetration, the fitted law's own smoothing length; OpenSim's default 300 would
spread it over 3 mm, a large part of the 5-10 mm a unit penetrates)."""
HUNT_CROSSLEY_SMOOTHING = 50.0
"""[s/m] OpenSim's ``hunt_crossley_smoothing`` (its default)."""
CONSTANT_CONTACT_FORCE = 1e-8
"""OpenSim's ``constant_contact_force`` [m^2 and (m/s)^2]: the small constant under its square
roots (penetration and slip speed); 1e-8 puts them at 0.1 mm and 0.1 mm/s (default 1e-5: 3 mm)."""
HERTZ_GAIN = 4.0 / 3.0 * 2.0**-1.5
"""``K = HERTZ_GAIN * E * sqrt(R)``: Simbody's ``(4/3) k sqrt(R k)`` with ``k = E^(2/3) / 2``."""


LAB_TO_Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""``lab`` (Z up) -> OpenSim (Y up); the same as :data:`gc_ocp.export.opensim_files.LAB_TO_Y_UP`
(this script imports nothing of gc_ocp: module doc)."""


def _require_opensim():
    try:
        import opensim

        opensim.Logger.removeFileSink()  # no opensim.log in the user's working folder
    except ImportError:
        raise ModelError(
            "The OpenSim export needs the opensim package: pip install 'gc_ocp[opensim]' "
            "(or pip install opensim)."
        ) from None
    return opensim


# --- the URDF, read ------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class UrdfLink:
    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray  # (ixx, iyy, izz, ixy, ixz, iyz) about the com


@dataclasses.dataclass(frozen=True)
class UrdfJoint:
    name: str
    kind: str
    parent: str
    child: str
    xyz: np.ndarray
    rotation: np.ndarray  # 3x3, child frame in parent at q = 0
    axis: np.ndarray
    limits: tuple[float, float] | None


def _vec(text: str | None, default=(0.0, 0.0, 0.0)) -> np.ndarray:
    return np.array([float(v) for v in text.split()] if text else default, float)


def read_urdf(text: str) -> tuple[dict[str, UrdfLink], list[UrdfJoint]]:
    """The links (with their inertia) and joints (in file order) of a URDF."""
    root = ET.fromstring(text)
    links = {}
    for el in root.findall("link"):
        inertial = el.find("inertial")
        if inertial is None:
            links[el.get("name")] = UrdfLink(el.get("name"), 0.0, np.zeros(3), np.zeros(6))
            continue
        origin = inertial.find("origin")
        if origin is not None and np.any(_vec(origin.get("rpy"))):
            raise ModelError(
                f"URDF link {el.get('name')}: a rotated inertial frame is not supported"
            )
        i = inertial.find("inertia").attrib
        links[el.get("name")] = UrdfLink(
            el.get("name"),
            float(inertial.find("mass").get("value")),
            _vec(None if origin is None else origin.get("xyz")),
            np.array([float(i.get(k, 0.0)) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")]),
        )
    joints = []
    for el in root.findall("joint"):
        origin = el.find("origin")
        axis = el.find("axis")
        lim = el.find("limit")
        rpy = _vec(None if origin is None else origin.get("rpy"))
        joints.append(
            UrdfJoint(
                el.get("name"),
                el.get("type"),
                el.find("parent").get("link"),
                el.find("child").get("link"),
                _vec(None if origin is None else origin.get("xyz")),
                Rotation.from_euler("xyz", rpy).as_matrix(),  # URDF: fixed-axis roll, pitch, yaw
                _vec(None if axis is None else axis.get("xyz"), (1.0, 0.0, 0.0)),
                None
                if lim is None or lim.get("lower") is None
                else (float(lim.get("lower")), float(lim.get("upper"))),
            )
        )
    return links, joints


def _euler_xyz(R: np.ndarray) -> tuple[float, float, float]:
    """OpenSim's frame orientation: body-fixed X-Y-Z angles of ``R``."""
    return tuple(float(a) for a in Rotation.from_matrix(R).as_euler("XYZ"))


# --- the OpenSim model ---------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class SphereUnit:
    """One contact unit as OpenSim has it: ``side``, ``unit``, the ``body`` it is on, the
    sphere centre ``location`` in that body [m], and the force's parameters."""

    side: str
    unit: str
    body: str
    location: np.ndarray
    stiffness: float
    dissipation: float
    friction: float
    transition_velocity: float
    static_friction: float | None = None  # None: the (dynamic) friction

    @property
    def name(self) -> str:
        return f"contact_{self.unit}_{self.side[0]}"


def _chains(links: dict, joints: list) -> list[tuple[str, list]]:
    """``[(body, [joints])]``: each massive link with the chain of joints from its massive
    parent (or the ground) through massless links, in file order (module doc). A unit frame
    (a massless leaf on a fixed joint) is no body."""
    by_parent: dict[str, list] = {}
    for j in joints:
        by_parent.setdefault(j.parent, []).append(j)
    out = []
    for j in joints:
        parent_massless = j.parent != "ground" and links[j.parent].mass == 0.0
        if parent_massless:
            continue  # inside a chain: taken with its first joint
        chain, cur = [j], j.child
        while links[cur].mass == 0.0:
            nxt = by_parent.get(cur, [])
            if not nxt:
                break  # a unit frame
            if len(nxt) != 1 or np.any(nxt[0].xyz) or not np.allclose(nxt[0].rotation, np.eye(3)):
                raise ModelError(
                    f"URDF link {cur}: a massless link with an offset or several children "
                    "cannot be merged into one OpenSim joint"
                )
            chain.append(nxt[0])
            cur = nxt[0].child
        if links[cur].mass == 0.0:
            continue
        out.append((cur, chain))
    return out


def _spatial_transform(osim, chain: list):
    """A ``SpatialTransform`` of the chain: its revolute joints as successive (body-fixed)
    rotations about their axes, its prismatic joints as translations along theirs (in the
    parent frame: they come first in the URDF, so their order does not matter)."""
    rot = [j for j in chain if j.kind == "revolute"]
    tra = [j for j in chain if j.kind == "prismatic"]
    if len(rot) > 3 or len(tra) > 3 or len(rot) + len(tra) != len(chain):
        raise ModelError(f"URDF joints {[j.name for j in chain]}: not one OpenSim joint")
    if rot and tra and chain.index(tra[-1]) > chain.index(rot[0]):
        raise ModelError(f"URDF joints {[j.name for j in chain]}: a translation after a rotation")
    st = osim.SpatialTransform()
    for i, j in enumerate(rot):
        ax = st.updTransformAxis(i)
        ax.setCoordinateNames(osim.ArrayStr(j.name, 1))
        ax.set_axis(osim.Vec3(*(j.axis / np.linalg.norm(j.axis))))
        ax.set_function(osim.LinearFunction(1.0, 0.0))
    for i, j in enumerate(tra):
        ax = st.updTransformAxis(3 + i)
        ax.setCoordinateNames(osim.ArrayStr(j.name, 1))
        ax.set_axis(osim.Vec3(*(j.axis / np.linalg.norm(j.axis))))
        ax.set_function(osim.LinearFunction(1.0, 0.0))
    st.constructIndependentAxes(len(rot), 0)
    return st


def add_contact(model, spheres: list[SphereUnit], floor_height: float, radius: float) -> None:
    """Add the floor (a ``ContactHalfSpace`` at ``floor_height`` on OpenSim's Y-up ground) and
    one contact sphere with its ``SmoothSphereHalfSpaceForce`` per unit of ``spheres`` to
    ``model`` (whose bodies are named by the units' ``body``)."""
    osim = _require_opensim()
    bodies = model.getBodySet()
    floor = osim.ContactHalfSpace(
        osim.Vec3(0.0, float(floor_height), 0.0),
        osim.Vec3(0.0, 0.0, -math.pi / 2),  # the half space's x axis points down: solid below
        model.getGround(),
        "floor",
    )
    model.addContactGeometry(floor)
    for s in spheres:
        if not bodies.contains(s.body):
            raise ModelError(f"contact unit {s.name}: body {s.body} is not in the model")
        sphere = osim.ContactSphere(
            radius, osim.Vec3(*s.location), bodies.get(s.body), f"{s.name}_sphere"
        )
        model.addContactGeometry(sphere)
        force = osim.SmoothSphereHalfSpaceForce(s.name, sphere, floor)
        force.set_stiffness(s.stiffness)
        force.set_dissipation(s.dissipation)
        force.set_static_friction(s.friction if s.static_friction is None else s.static_friction)
        force.set_dynamic_friction(s.friction)
        force.set_viscous_friction(0.0)
        force.set_transition_velocity(s.transition_velocity)
        force.set_constant_contact_force(CONSTANT_CONTACT_FORCE)
        force.set_hertz_smoothing(HERTZ_SMOOTHING)
        force.set_hunt_crossley_smoothing(HUNT_CROSSLEY_SMOOTHING)
        model.addForce(force)


def _remove_named(model, spheres: list[SphereUnit]) -> None:
    """Remove from ``model`` the forces and contact geometry named as this export names its
    own (an earlier export's), so that exporting into an exported model replaces them; the
    model's other contact stays."""
    forces = model.updForceSet()
    geometry = model.updContactGeometrySet()
    for s in spheres:
        if forces.getIndex(s.name) >= 0:
            forces.remove(forces.getIndex(s.name))
    for name in ["floor", *(f"{s.name}_sphere" for s in spheres)]:
        if geometry.getIndex(name) >= 0:
            geometry.remove(geometry.getIndex(name))


def build_model(
    urdf: str,
    spheres: list[SphereUnit],
    floor_height: float,
    radius: float = DEFAULT_RADIUS,
    name: str = "gc_ocp_subject",
    markers: list[dict] | None = None,
):
    """An ``opensim.Model`` of the URDF's body with ``spheres`` on the floor (module doc) and
    ``markers`` (``{"name", "body", "location"}``: the registered markers, for OpenSim's own
    inverse kinematics)."""
    osim = _require_opensim()
    links, joints = read_urdf(urdf)
    model = osim.Model()
    model.setName(name)
    model.setGravity(osim.Vec3(0.0, -9.80665, 0.0))
    kept = {"ground": model.getGround()}
    for child, chain in _chains(links, joints):
        link = links[child]
        body = osim.Body(child, link.mass, osim.Vec3(*link.com), osim.Inertia(*link.inertia))
        model.addBody(body)
        first = chain[0]
        R_parent, xyz = first.rotation, first.xyz
        if first.parent == "ground":  # OpenSim's ground is Y up
            R_parent, xyz = LAB_TO_Y_UP @ R_parent, LAB_TO_Y_UP @ xyz
        frames = (
            kept[first.parent],
            osim.Vec3(*xyz),
            osim.Vec3(*_euler_xyz(R_parent)),
            body,
            osim.Vec3(0.0, 0.0, 0.0),
            osim.Vec3(0.0, 0.0, 0.0),
        )
        if first.kind == "fixed":
            joint = osim.WeldJoint(first.name, *frames)
        else:
            joint = osim.CustomJoint(child, *frames, _spatial_transform(osim, chain))
        model.addJoint(joint)
        kept[child] = body
    for m in markers or []:
        model.addMarker(osim.Marker(m["name"], kept[m["body"]], osim.Vec3(*m["location"])))
    add_contact(model, spheres, floor_height, radius)
    model.finalizeConnections()  # the custom joints' coordinates exist from here
    coords = model.updCoordinateSet()
    for j in joints:
        if j.kind in ("revolute", "prismatic"):
            c = coords.get(j.name)
            if j.limits is not None:
                c.setRangeMin(j.limits[0])
                c.setRangeMax(j.limits[1])
            c.setDefaultValue(0.0)
    return model


# --- the jobs --------------------------------------------------------------------------------


def contact_forces(model, coordinates, q, qdot, spheres) -> dict:
    """OpenSim's force of every sphere on its foot over the frames ``q``, ``qdot``
    ``(n, len(coordinates))``: ``{name: (n, 6)}``, force [N] and its moment [N m] about the
    ground origin, in OpenSim's ground frame."""
    osim = _require_opensim()
    state = model.initSystem()
    cs = model.getCoordinateSet()
    coords = [cs.get(c) for c in coordinates]
    forces = {
        s.name: osim.SmoothSphereHalfSpaceForce.safeDownCast(model.getForceSet().get(s.name))
        for s in spheres
    }
    out = {name: np.zeros((len(q), 6)) for name in forces}
    for k in range(len(q)):
        for c, v, w in zip(coords, q[k], qdot[k], strict=True):
            c.setValue(state, float(v), False)
            c.setSpeedValue(state, float(w))
        model.realizeVelocity(state)
        for name, f in forces.items():
            arr = f.getRecordLabels()
            labels = [arr.get(i) for i in range(arr.getSize())]
            values = f.getRecordValues(state)
            rec = {lab: values.get(i) for i, lab in enumerate(labels)}
            # the half space (ground) records the force on it and its torque about the ground
            # origin; the foot gets the opposite of both (the same point of application)
            g = [lab for lab in labels if ".HalfSpace." in lab]
            fg = np.array([rec[x] for x in g if ".force." in x])
            tg = np.array([rec[x] for x in g if ".torque." in x])
            out[name][k] = -np.r_[fg, tg]
    return out


def body_poses(model, coordinates, q, bodies) -> dict:
    """``{body: (n, 4, 4)}``: each body's placement in OpenSim's ground over the frames ``q``."""
    state = model.initSystem()
    cs = model.getCoordinateSet()
    coords = [cs.get(c) for c in coordinates]
    out = {b: np.zeros((len(q), 4, 4)) for b in bodies}
    for k in range(len(q)):
        for c, v in zip(coords, q[k], strict=True):
            c.setValue(state, float(v), False)
        model.realizePosition(state)
        for b in bodies:
            T = model.getBodySet().get(b).getTransformInGround(state)
            out[b][k, :3, :3] = [[T.R().get(i, j) for j in range(3)] for i in range(3)]
            out[b][k, :3, 3] = [T.p().get(i) for i in range(3)]
            out[b][k, 3, 3] = 1.0
    return out


def inverse_dynamics(job: dict) -> str:
    """OpenSim's inverse dynamics on an exported folder: ``job`` gives the ``model``,
    ``coordinates``, ``external_loads`` files, the ``results`` folder and the time range;
    the model's own forces (the contact spheres) are excluded, the ground reactions being the
    external loads. Returns the generalized forces' file."""
    osim = _require_opensim()
    model = osim.Model(job["model"])
    tool = osim.InverseDynamicsTool()
    tool.setModel(model)
    tool.setCoordinatesFileName(job["coordinates"])
    tool.setExternalLoadsFileName(job["external_loads"])
    tool.setStartTime(job["start"])
    tool.setEndTime(job["end"])
    tool.setLowpassCutoffFrequency(-1.0)
    excluded = osim.ArrayStr()
    excluded.append("All")
    tool.setExcludedForces(excluded)
    tool.setResultsDir(job["results"])
    tool.setOutputGenForceFileName("inverse_dynamics.sto")
    if not tool.run():
        raise RuntimeError("OpenSim's InverseDynamicsTool reported a failure")
    return str(Path(job["results"]) / "inverse_dynamics.sto")


def run(job: dict) -> dict:
    """Carry out one job (module doc) and return the reply."""
    if "inverse_dynamics" in job:
        return {"inverse_dynamics": inverse_dynamics(job["inverse_dynamics"])}
    spheres = [
        SphereUnit(**{**s, "location": np.asarray(s["location"], float)}) for s in job["spheres"]
    ]
    if job.get("model"):  # the user's own model: the contact added to it
        model = _require_opensim().Model(job["model"])
        model.setName(job["name"])
        _remove_named(model, spheres)
        add_contact(model, spheres, job["floor_height"], job["radius"])
        model.finalizeConnections()
    else:
        model = build_model(
            job["urdf"],
            spheres,
            job["floor_height"],
            job["radius"],
            job["name"],
            job.get("markers"),
        )
    reply = {}
    if job.get("osim"):
        model.printToXML(job["osim"])
        reply["osim"] = job["osim"]
    fj = job.get("forces")
    if fj:
        data = np.load(fj["frames"])
        out = contact_forces(model, list(data["coordinates"]), data["q"], data["qdot"], spheres)
        np.savez(fj["out"], **out)
        reply["forces"] = fj["out"]
    pj = job.get("poses")
    if pj:
        data = np.load(pj["frames"])
        out = body_poses(model, list(data["coordinates"]), data["q"], pj["bodies"])
        np.savez(pj["out"], **out)
        reply["poses"] = pj["out"]
    return reply


def main(argv=None) -> int:
    import json
    import sys

    argv = sys.argv[1:] if argv is None else argv
    try:
        with open(argv[0]) as fh:
            job = json.load(fh)
        reply = run(job)
    except Exception as e:  # reported to the calling process, which raises it as its own error
        print(json.dumps({"error": f"{type(e).__name__}: {e}"}))
        return 1
    print(json.dumps(reply))
    return 0


__all__ = (
    "DEFAULT_RADIUS",
    "SphereUnit",
    "add_contact",
    "body_poses",
    "build_model",
    "contact_forces",
    "read_urdf",
)


if __name__ == "__main__":
    raise SystemExit(main())
