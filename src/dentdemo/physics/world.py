"""The physics world over ODE: bodies, shapes, contact joints and impact events.

World space: metres, right-handed, +Y up. Quaternions are (w, x, y, z) as ODE has them. A body's
pose is that of its own origin (for a plate: the centre of its top face); ODE's body sits at the
centre of mass, `com_offset` (body-local) away.
"""

from __future__ import annotations

import ctypes
import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dentdemo import interrupt
from dentdemo.model.impulse import pair_impulses
from dentdemo.model.pose import pose_matrix, quat_to_matrix  # noqa: F401 (re-exported)
from dentdemo.model.scene import BodySpec, PhysicsSpec
from dentdemo.model.shapes import Capsule, Cylinder, MeshFile, Plane, Sphere
from dentdemo.physics.geoms import body_mass, destroy_geom, make_geom, trimesh_geom
from dentdemo.physics.ode import Handle, fast, ode

MAX_CONTACTS = 8
#: Metres of penetration a contact of two triangle meshes may hold beyond what the approach in
#: one substep brings (what the solver leaves of earlier substeps, under load): deeper ones are
#: phantoms of ODE's mesh-mesh collider (`PhysicsWorld._plausible`).
PHANTOM_SLACK = 2e-3
#: Constraint force mixing: near-rigid contacts. A soft CFM damps bounces more the smaller the
#: step, which would make restitution depend on dt.
CONTACT_CFM = 1e-9
_CONTACT_MODE = ode.dContactBounce | ode.dContactSoftCFM | ode.dContactApprox1
#: With rolling resistance: ODE's rolling rows (limits proportional to the normal force, as
#: dContactApprox1 makes them), and the contact frame's first axis given (fdir1, set per contact
#: along the relative spin) so that one row of limit rho * N resists the rolling, whatever its
#: direction: ODE bounds each axis on its own, which would give up to sqrt(2) rho N diagonally.
_ROLLING_MODE = _CONTACT_MODE | ode.dContactRolling
#: Below this relative spin, rad/s, the contact frame is ODE's own.
_SPIN_MIN = 1e-9
#: Below this slip speed, m/s, a touching pair is not sliding (rolling, resting): its wear is
#: not tracked. A ball rolling without slip on a plate slips ~1e-6 m/s in ODE's solution.
SLIP_MIN = 1e-3


@dataclass
class Impact:
    """One impact of a touching pair in one step. The normal points from body A towards body B;
    B presses into A along -normal. Impulses in N*s (paper eq. 2), velocities in m/s at the
    contact point just before the step."""

    step: int
    time: float
    body_a: str
    body_b: str
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    depth: float
    vel_a: NDArray[np.float64]
    vel_b: NDArray[np.float64]
    mass_a: float  # kg; inf for a static body
    mass_b: float
    eps_a: float
    eps_b: float
    j: float
    j_elastic: float
    pose_a: tuple[NDArray[np.float64], NDArray[np.float64]]  # (position, quaternion w x y z)
    pose_b: tuple[NDArray[np.float64], NDArray[np.float64]]

    @property
    def approach_speed(self) -> float:
        return float(-(self.normal @ (self.vel_b - self.vel_a)))

    def as_dict(self) -> dict:
        def mass(m: float) -> float | None:
            return None if math.isinf(m) else m

        return {
            "step": self.step,
            "time": round(self.time, 9),
            "body_a": self.body_a,
            "body_b": self.body_b,
            "point": self.point.tolist(),
            "normal": self.normal.tolist(),
            "depth": self.depth,
            "vel_a": self.vel_a.tolist(),
            "vel_b": self.vel_b.tolist(),
            "mass_a": mass(self.mass_a),
            "mass_b": mass(self.mass_b),
            "eps_a": self.eps_a,
            "eps_b": self.eps_b,
            "approach_speed": self.approach_speed,
            "j": self.j,
            "j_elastic": self.j_elastic,
            "pose_a": {"position": self.pose_a[0].tolist(), "quaternion": self.pose_a[1].tolist()},
            "pose_b": {"position": self.pose_b[0].tolist(), "quaternion": self.pose_b[1].tolist()},
        }


@dataclass
class Slide:
    """A touching pair that slid during one step (its substeps together), for wear (PhysicsSpec
    .wear_scale > 0). As for an Impact the normal points from body A towards body B. `work` is
    the sum over substeps of the pair's normal force (N, from ODE's joint feedback) times the
    distance it slipped (m: the relative tangential speed at the deepest contact before the
    substep times its dt), N*m; Archard's volume is K work / H. `point` (world metres) and
    `normal` are the deepest contact's at the last substep that slid."""

    body_a: str
    body_b: str
    work: float
    slip: float
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    depth: float


@dataclass
class _Body:
    spec: BodySpec
    geom: Handle
    body: Handle | None  # None for static
    mass: float  # kg, inf when static
    com_offset: NDArray[np.float64]
    #: The ctypes buffers ODE points into: a triangle-mesh geom's (empty for any other geom).
    keep_alive: list = field(default_factory=list)
    body_addr: int | None = None  # the dBodyID as an integer, for the hot path
    #: Lever of the rolling resistance, m: from the centre of mass to where the body rests.
    rolling_radius: float = 0.0
    #: A mesh shape's triangles (body space), to make its geom again (`reset_shape`).
    mesh_arrays: tuple[NDArray, NDArray] | None = None


@dataclass(frozen=True)
class WorldState:
    """A PhysicsWorld as `snapshot` saw it (floats as ODE stores them, metres, m/s, rad/s)."""

    time: float
    step_index: int
    seed: int
    #: Body ids in the collision space's order.
    order: list[str]
    #: Dynamic bodies: (centre of mass, quaternion w x y z, linear, angular velocity).
    bodies: dict[str, tuple[list[float], list[float], list[float], list[float]]]


def rolling_radius(
    spec: BodySpec, mesh_arrays: tuple[NDArray, NDArray] | None, com: NDArray[np.float64]
) -> float:
    """The lever of a body's rolling resistance, m: a round shape's radius; a mesh's farthest
    vertex from its centre of mass (a disc or ring rolling on its rim). 0, no rolling rows, for
    what does not roll (boxes, plates, the ground): it tips or slides, and ODE's solver is spared
    three rows per contact."""
    match spec.shape:
        case Sphere(radius=r) | Capsule(radius=r) | Cylinder(radius=r):
            return float(r)
        case MeshFile() if mesh_arrays is not None:
            return float(np.linalg.norm(np.asarray(mesh_arrays[0]) - com, axis=1).max())
    return 0.0


def pair_surface(r1: _Body, r2: _Body) -> tuple[float, float, float]:
    """A touching pair's contact surface: mu (geometric mean of the two), bounce (the smaller
    restitution) and rho, m: the larger rolling coefficient C_rr of the two (the lossier surface
    rules) times the rolling radius of the moving body that rolls (the smaller of two), so the
    resisting torque C_rr * N * R is that of a force C_rr * N at the rolling radius."""
    m1, m2 = r1.spec.material, r2.spec.material
    moving = [r.rolling_radius for r in (r1, r2) if r.body is not None and r.rolling_radius > 0]
    rho = max(m1.rolling_friction, m2.rolling_friction) * min(moving, default=0.0)
    return math.sqrt(m1.friction * m2.friction), min(m1.restitution, m2.restitution), rho


def _spin_axis(spin: tuple[float, float, float], normal: Handle, fdir1: Handle) -> int:
    """Set `fdir1` along the part of `spin` in the contact plane (the axis the pair rolls
    about) and return dContactFDir1; 0 (ODE's own frame) when it hardly spins."""
    nx, ny, nz = normal[0], normal[1], normal[2]
    along = spin[0] * nx + spin[1] * ny + spin[2] * nz
    tx, ty, tz = spin[0] - along * nx, spin[1] - along * ny, spin[2] - along * nz
    length = math.sqrt(tx * tx + ty * ty + tz * tz)
    if length < _SPIN_MIN:
        return 0
    fdir1[0], fdir1[1], fdir1[2] = tx / length, ty / length, tz / length
    return int(ode.dContactFDir1)


def _addr(ptr: Handle) -> int:
    return ctypes.cast(ptr, ctypes.c_void_p).value or 0


class PhysicsWorld:
    """A deterministic ODE world stepped at a fixed dt with substeps."""

    def __init__(self, spec: PhysicsSpec) -> None:
        self.spec = spec
        ode.dRandSetSeed(0)  # QuickStep reorders constraints randomly: same seed, same run
        self.world = ode.dWorldCreate()
        ode.dWorldSetGravity(self.world, *spec.gravity)
        ode.dWorldSetERP(self.world, 0.2)
        ode.dWorldSetCFM(self.world, CONTACT_CFM)
        ode.dWorldSetContactSurfaceLayer(self.world, 1e-4)
        ode.dWorldSetContactMaxCorrectingVel(self.world, 0.5)
        ode.dWorldSetQuickStepNumIterations(self.world, spec.solver_iterations)
        self.space = ode.dSimpleSpaceCreate(None)  # insertion order: deterministic
        self.contact_group = ode.dJointGroupCreate(0)
        self.bodies: dict[str, _Body] = {}
        self._by_geom: dict[int, _Body] = {}
        self.step_index = 0
        self.time = 0.0
        self.removed: list[str] = []
        self._contacts = (ode.dContact * MAX_CONTACTS)()
        self._contacts_addr = ctypes.addressof(self._contacts)
        self._contact_addrs = [
            self._contacts_addr + i * ctypes.sizeof(ode.dContact) for i in range(MAX_CONTACTS)
        ]
        self._geom_offset = ode.dContact.geom.offset
        for contact in self._contacts:  # what every contact shares; collide fills only .geom
            contact.surface.mode = _CONTACT_MODE
            contact.surface.bounce_vel = spec.impact_speed_min
            contact.surface.soft_cfm = CONTACT_CFM
        # Views into the contact slots, made once: ctypes makes a new object per field access,
        # and the near callback runs for every touching pair in every substep.
        self._slots = [
            (contact.surface, contact.geom, contact.fdir1, address)
            for contact, address in zip(self._contacts, self._contact_addrs, strict=True)
        ]
        self._callback = fast.near_callback_type(self._near)
        self._world_addr = _addr(self.world)
        self._group_addr = _addr(self.contact_group)
        self._space_addr = _addr(self.space)
        #: (mu, bounce, rho in m) of a touching pair of geoms, made on first touch.
        self._pair_surface: dict[tuple[int, int], tuple[float, float, float]] = {}
        self._pending: dict[tuple[str, str], Impact] = {}
        self._callback_error: BaseException | None = None
        self._vel_buffer = (ode.dReal * 4)()
        self._vel_addr = ctypes.addressof(self._vel_buffer)
        #: The pairs that slid in the last step, by (body A, body B) (wear tracked only).
        self.slides: dict[tuple[str, str], Slide] = {}
        self._wear = spec.wear_scale > 0.0
        #: Joint feedback records, reused: the sliding contacts of one substep take the first.
        self._feedback: list = []
        #: This substep's sliding pairs: (A, B, feedback slice, slip m/s, contact geom fields).
        self._sliding: list[tuple] = []
        self._feedback_used = 0

    # -- bodies --------------------------------------------------------------------------------
    def add_body(self, spec: BodySpec, mesh_arrays: tuple[NDArray, NDArray] | None = None) -> None:
        """Add a body; a `mesh` shape needs (positions (n, 3) m, indices (m, 3)) in body space."""
        if spec.id in self.bodies:
            raise ValueError(f"duplicate body id '{spec.id}'")
        shape = spec.shape
        geom, keep, com = make_geom(self.space, spec, mesh_arrays)
        record = _Body(spec, geom, None, math.inf, com, keep, mesh_arrays=mesh_arrays)
        record.rolling_radius = rolling_radius(spec, mesh_arrays, com)
        if not spec.static and not isinstance(shape, Plane):
            try:
                mass, com = body_mass(spec, geom, mesh_arrays, com)
            except ValueError:
                destroy_geom(geom, keep)
                raise
            body = ode.dBodyCreate(self.world)
            ode.dBodySetMass(body, ctypes.byref(mass))
            ode.dGeomSetBody(geom, body)
            if isinstance(shape, MeshFile) and np.any(com != 0):
                ode.dGeomSetOffsetPosition(geom, *(-com))
            record.body, record.mass, record.com_offset = body, float(mass.mass), com
            record.body_addr = _addr(body)
            ode.dBodySetLinearVel(body, *spec.velocity)
            ode.dBodySetAngularVel(body, *spec.angular_velocity)
        self.bodies[spec.id] = record
        self._by_geom[_addr(geom)] = record
        if not isinstance(shape, Plane):
            self.set_pose(spec.id, np.asarray(spec.position), np.asarray(spec.orientation))

    def remove_body(self, body_id: str) -> None:
        record = self.bodies.pop(body_id)
        self._by_geom.pop(_addr(record.geom), None)
        self._forget_pairs(record.geom)
        destroy_geom(record.geom, record.keep_alive)
        if record.body is not None:
            ode.dBodyDestroy(record.body)

    def set_spec(self, spec: BodySpec) -> None:
        """Give the body `spec.id` a new spec that differs in its material only (a hot-reloaded
        preset): friction, restitution and, for a dynamic body, mass from the new density; its
        pose and velocities are kept."""
        record = self.bodies[spec.id]
        self._forget_pairs(record.geom)
        old_density = record.spec.material.density
        record.spec = spec
        if record.body is not None and spec.material.density != old_density:
            # One density throughout: mass and inertia scale with it, the centre stays.
            mass = ode.dMass()
            ode.dBodyGetMass(record.body, ctypes.byref(mass))
            ode.dMassAdjust(ctypes.byref(mass), mass.mass * spec.material.density / old_density)
            ode.dBodySetMass(record.body, ctypes.byref(mass))
            record.mass = float(mass.mass)

    def _forget_pairs(self, geom: Handle) -> None:
        """Drop the contact surfaces made for `geom`'s pairs (its material or geom changed)."""
        gone = _addr(geom)
        self._pair_surface = {k: v for k, v in self._pair_surface.items() if gone not in k}

    def set_surface(self, body_id: str, positions: NDArray, indices: NDArray) -> None:
        """Make a dynamic body's collision shape the closed triangles `positions` (n, 3), in its
        local frame, metres, and `indices` (m, 3), wound outwards: its dented surface
        (app/reshape.py). Its mass, inertia, pose and velocities are kept, and so is its place
        in the collision space's order (collision order drives QuickStep)."""
        record = self.bodies[body_id]
        if record.body is None:
            raise ValueError(f"body '{body_id}' is static: its shape does not follow its dents")
        geom, keep = trimesh_geom(self.space, positions, indices)
        self._replace_geom(record, geom, keep, -record.com_offset)

    def reset_shape(self, body_id: str) -> None:
        """Give a body back the collision shape its spec makes (after `set_surface`)."""
        record = self.bodies[body_id]
        geom, keep, _ = make_geom(self.space, record.spec, record.mesh_arrays)
        offset = -record.com_offset if isinstance(record.spec.shape, MeshFile) else np.zeros(3)
        self._replace_geom(record, geom, keep, offset)

    def _replace_geom(self, record: _Body, geom: Handle, keep: list, offset: NDArray) -> None:
        """`geom` (just made in the space) takes the place of `record`'s geom: its body, the
        geom's offset from the body (metres), its place in the space's order."""
        old = record.geom
        order = [ode.dSpaceGetGeom(self.space, i) for i in range(ode.dSpaceGetNumGeoms(self.space))]
        order = [g for g in order if _addr(g) != _addr(geom)]  # made at the front: not yet placed
        at = next(i for i, g in enumerate(order) if _addr(g) == _addr(old))
        if record.body is not None:
            ode.dGeomSetBody(geom, record.body)
            if np.any(offset != 0):
                ode.dGeomSetOffsetPosition(geom, *offset)
        self._by_geom.pop(_addr(old), None)
        self._forget_pairs(old)
        destroy_geom(old, record.keep_alive)
        # The new geom takes the old one's place (dSpaceAdd puts a geom at the front).
        for g in reversed([*order[:at], geom, *order[at + 1 :]]):
            ode.dSpaceRemove(self.space, g)
            ode.dSpaceAdd(self.space, g)
        record.geom, record.keep_alive = geom, keep
        self._by_geom[_addr(geom)] = record

    def set_pose(self, body_id: str, position: NDArray, quaternion: NDArray) -> None:
        record = self.bodies[body_id]
        q = np.asarray(quaternion, dtype=np.float64)
        q = q / np.linalg.norm(q)
        centre = np.asarray(position, dtype=np.float64) + quat_to_matrix(q) @ record.com_offset
        qd = (ode.dReal * 4)(*q)
        if record.body is not None:
            ode.dBodySetPosition(record.body, *centre)
            ode.dBodySetQuaternion(record.body, qd)
        else:
            ode.dGeomSetPosition(record.geom, *centre)
            ode.dGeomSetQuaternion(record.geom, qd)

    def set_velocity(
        self, body_id: str, linear: ArrayLike, angular: ArrayLike = (0.0, 0.0, 0.0)
    ) -> None:
        record = self.bodies[body_id]
        if record.body is not None:
            ode.dBodySetLinearVel(record.body, *np.asarray(linear, dtype=np.float64))
            ode.dBodySetAngularVel(record.body, *np.asarray(angular, dtype=np.float64))

    def pose(self, body_id: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(position of the body's origin, quaternion w x y z), world."""
        record = self.bodies[body_id]
        if isinstance(record.spec.shape, Plane):
            return np.asarray(record.spec.position, dtype=np.float64), np.array([1.0, 0, 0, 0])
        if record.body is not None:
            p = ode.dBodyGetPosition(record.body)
            q = ode.dBodyGetQuaternion(record.body)
        else:
            p = ode.dGeomGetPosition(record.geom)
            q = (ode.dReal * 4)()
            ode.dGeomGetQuaternion(record.geom, q)
        quat = np.array([q[0], q[1], q[2], q[3]], dtype=np.float64)
        centre = np.array([p[0], p[1], p[2]], dtype=np.float64)
        return centre - quat_to_matrix(quat) @ record.com_offset, quat

    def velocity(self, body_id: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        record = self.bodies[body_id]
        if record.body is None:
            return np.zeros(3), np.zeros(3)
        v = ode.dBodyGetLinearVel(record.body)
        w = ode.dBodyGetAngularVel(record.body)
        return np.array([v[0], v[1], v[2]]), np.array([w[0], w[1], w[2]])

    def model_matrix(self, body_id: str) -> NDArray[np.float64]:
        """World from body-local 4x4 (column vectors)."""
        return pose_matrix(*self.pose(body_id))

    def ray_pick(
        self, origin: ArrayLike, direction: ArrayLike, length: float = 100.0
    ) -> str | None:
        """The body whose collision shape a ray (world origin, direction, metres) meets first,
        or None. ODE's ray geom, outside the space: the simulation never sees it."""
        o = np.asarray(origin, dtype=np.float64)
        d = np.asarray(direction, dtype=np.float64)
        d = d / np.linalg.norm(d)
        ray = ode.dCreateRay(None, length)
        try:
            ode.dGeomRaySet(ray, *o, *d)
            ode.dGeomRaySetClosestHit(ray, 1)
            contact = ode.dContactGeom()
            best, nearest = None, math.inf
            for body_id, record in self.bodies.items():
                size = ctypes.sizeof(contact)
                hits = ode.dCollide(ray, record.geom, 1, ctypes.byref(contact), size)
                if hits > 0 and contact.depth < nearest:
                    best, nearest = body_id, float(contact.depth)
            return best
        finally:
            ode.dGeomDestroy(ray)

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> list[Impact]:
        """Advance one frame step (spec.dt) in spec.substeps ODE steps; return its impacts, at most
        one per touching pair (the one with the largest j_elastic), sorted by body ids."""
        interrupt.check()
        self._pending = {}
        self.slides = {}
        sub_dt = self.spec.dt / self.spec.substeps
        for _ in range(self.spec.substeps):
            self._sliding = []
            self._feedback_used = 0
            fast.space_collide(self._space_addr, None, self._callback)
            if self._callback_error is not None:  # Ctrl-C or a bug inside the callback
                error, self._callback_error = self._callback_error, None
                ode.dJointGroupEmpty(self.contact_group)
                raise error
            ode.dWorldQuickStep(self.world, sub_dt)
            if self._sliding:
                self._add_slides(sub_dt)
            ode.dJointGroupEmpty(self.contact_group)
            self.time += sub_dt
        self._drop_non_finite()
        self.step_index += 1
        return [self._pending[k] for k in sorted(self._pending)]

    def _drop_non_finite(self) -> None:
        for body_id in list(self.bodies):
            record = self.bodies[body_id]
            if record.body is None:
                continue
            p = ode.dBodyGetPosition(record.body)
            q = ode.dBodyGetQuaternion(record.body)
            v = ode.dBodyGetLinearVel(record.body)
            w = ode.dBodyGetAngularVel(record.body)
            total = (
                p[0]
                + p[1]
                + p[2]
                + q[0]
                + q[1]
                + q[2]
                + q[3]
                + v[0]
                + v[1]
                + v[2]
                + w[0]
                + w[1]
                + w[2]
            )
            if not math.isfinite(total):
                warnings.warn(
                    f"body '{body_id}' became non-finite at t = {self.time:.4f} s; removed",
                    RuntimeWarning,
                    stacklevel=3,
                )
                self.remove_body(body_id)
                self.removed.append(body_id)

    def _near(self, data: int | None, g1: int, g2: int) -> None:
        """ODE's near callback. An exception here (Ctrl-C above all) would be printed and
        swallowed by ctypes: keep it, skip the remaining pairs, and raise it after the collide."""
        if self._callback_error is not None:
            return
        try:
            self._near_pair(g1, g2)
        except BaseException as exc:  # noqa: BLE001 - re-raised by step()
            self._callback_error = exc

    def _near_pair(self, g1: int, g2: int) -> None:
        r1 = self._by_geom.get(g1)
        r2 = self._by_geom.get(g2)
        if r1 is None or r2 is None or (r1.body is None and r2.body is None):
            return
        count = fast.collide(
            g1,
            g2,
            MAX_CONTACTS,
            self._contacts_addr + self._geom_offset,
            ctypes.sizeof(ode.dContact),
        )
        if count <= 0:
            return
        key = (g1, g2)
        surface = self._pair_surface.get(key)
        if surface is None:
            surface = pair_surface(r1, r2)
            self._pair_surface[key] = surface
        mu, bounce, rho = surface
        slots = self._slots[:count]
        if r1.keep_alive and r2.keep_alive:  # two triangle meshes (a mesh file or a proxy)
            slots = self._plausible(r1, r2, slots)
            if not slots:
                return
        deepest, best = slots[0][1], -math.inf
        world, group, body1, body2 = self._world_addr, self._group_addr, r1.body_addr, r2.body_addr
        spin = self._relative_spin(r1, r2) if rho > 0.0 else None
        joints = []
        for surface_, geom, fdir1, address in slots:
            surface_.mu = mu  # bounce_vel and soft_cfm are set once (__init__)
            surface_.bounce = bounce
            if spin is None:
                surface_.mode = _CONTACT_MODE
            else:
                surface_.rho = rho
                surface_.mode = _ROLLING_MODE | _spin_axis(spin, geom.normal, fdir1)
            depth = geom.depth
            if depth > best:
                deepest, best = geom, depth
            joint = fast.create_contact(world, group, address)
            fast.attach(joint, body1, body2)
            joints.append(joint)
        if self._wear:
            self._watch_slip(r2, r1, deepest, joints)
        # ODE's normal points into g1: from body A = owner of g2 towards body B = owner of g1.
        self._record(r2, r1, deepest)

    def _watch_slip(self, a: _Body, b: _Body, geom: Handle, joints: list[int]) -> None:
        """If A and B slip at their deepest contact (relative tangential speed above SLIP_MIN),
        ask ODE for the force of each of the pair's contact joints this substep."""
        if a.spec.material.wear_coefficient <= 0 and b.spec.material.wear_coefficient <= 0:
            return
        px, py, pz = geom.pos[0], geom.pos[1], geom.pos[2]
        n = (geom.normal[0], geom.normal[1], geom.normal[2])
        slip = self._slip_speed(a, b, px, py, pz, n)
        if slip <= SLIP_MIN:
            return
        first = self._feedback_used
        self._feedback_used += len(joints)
        while len(self._feedback) < first + len(joints):
            self._feedback.append(ode.dJointFeedback())
        records = self._feedback[first : first + len(joints)]
        for joint, record in zip(joints, records, strict=True):
            fast.set_feedback(joint, ctypes.addressof(record))
        point = np.array([px, py, pz], dtype=np.float64)
        self._sliding.append((a, b, records, slip, point, np.array(n), float(geom.depth)))

    def _slip_speed(
        self, a: _Body, b: _Body, x: float, y: float, z: float, n: tuple[float, float, float]
    ) -> float:
        """Relative tangential speed of B's and A's material points at world (x, y, z), m/s."""
        va, vb = self._point_velocity(a, x, y, z), self._point_velocity(b, x, y, z)
        rel = (vb[0] - va[0], vb[1] - va[1], vb[2] - va[2])
        along = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
        tx, ty, tz = rel[0] - along * n[0], rel[1] - along * n[1], rel[2] - along * n[2]
        return math.sqrt(tx * tx + ty * ty + tz * tz)

    def _add_slides(self, sub_dt: float) -> None:
        """This substep's slip of each sliding pair times its normal force (the joints' forces
        along the normal, ODE's feedback after the step) into the step's `slides`. The slip is
        the mean of the speeds before and after the substep (the trapezoid rule: a skid's slip
        speed falls linearly, and the speed before alone overstates it by half a substep's
        fall)."""
        for a, b, records, before, point, normal, depth in self._sliding:
            n = (float(normal[0]), float(normal[1]), float(normal[2]))
            x, y, z = (float(c) for c in point)
            slip = 0.5 * (before + self._slip_speed(a, b, x, y, z, n))
            force = 0.0
            for record in records:
                # ODE may swap a joint's bodies (a static first body): either force will do.
                f1, f2 = record.f1, record.f2
                along1 = f1[0] * normal[0] + f1[1] * normal[1] + f1[2] * normal[2]
                along2 = f2[0] * normal[0] + f2[1] * normal[1] + f2[2] * normal[2]
                force += max(abs(along1), abs(along2))
            key = (a.spec.id, b.spec.id)
            distance = slip * sub_dt
            slide = self.slides.get(key)
            if slide is None:
                self.slides[key] = Slide(
                    a.spec.id, b.spec.id, force * distance, distance, point, normal, depth
                )
            else:
                slide.work += force * distance
                slide.slip += distance
                slide.point, slide.normal, slide.depth = point, normal, depth

    def _plausible(self, r1: _Body, r2: _Body, slots: list) -> list:
        """The contacts of two triangle meshes that are not ODE's phantoms. Its mesh-mesh
        collider reports, for faces lying flat on each other (a crate resting on a crate), edge
        contacts along the faces with normals in their plane and depths of centimetres (12 cm for
        a 20 cm crate landing flat): joints that spun the crate up and impacts that dented its
        sides to the material's bound. A contact is kept where its depth could have come about
        since the last substep: what the bodies' approach along its normal covers in a substep,
        plus what the solver leaves (PHANTOM_SLACK)."""
        sub_dt = self.spec.dt / self.spec.substeps
        kept = []
        for slot in slots:
            geom = slot[1]
            px, py, pz = geom.pos[0], geom.pos[1], geom.pos[2]
            v1, v2 = self._point_velocity(r1, px, py, pz), self._point_velocity(r2, px, py, pz)
            n = geom.normal
            # ODE's normal points into g1 (r1): r2 approaches r1 along -n.
            approach = n[0] * (v2[0] - v1[0]) + n[1] * (v2[1] - v1[1]) + n[2] * (v2[2] - v1[2])
            if geom.depth <= max(approach, 0.0) * sub_dt + PHANTOM_SLACK:
                kept.append(slot)
        return kept

    def _relative_spin(self, r1: _Body, r2: _Body) -> tuple[float, float, float]:
        """Angular velocity of r1 relative to r2, rad/s, world axes."""
        x = y = z = 0.0
        if r1.body_addr is not None:
            w = fast.angular_vel(r1.body_addr)
            x, y, z = w[0], w[1], w[2]
        if r2.body_addr is not None:
            w = fast.angular_vel(r2.body_addr)
            x, y, z = x - w[0], y - w[1], z - w[2]
        return (x, y, z)

    def _record(self, a: _Body, b: _Body, geom: Handle) -> None:
        px, py, pz = geom.pos[0], geom.pos[1], geom.pos[2]
        nx, ny, nz = geom.normal[0], geom.normal[1], geom.normal[2]
        va, vb = self._point_velocity(a, px, py, pz), self._point_velocity(b, px, py, pz)
        approach = -(nx * (vb[0] - va[0]) + ny * (vb[1] - va[1]) + nz * (vb[2] - va[2]))
        if approach <= self.spec.impact_speed_min:
            return  # resting or separating: not an impact
        point = np.array([px, py, pz], dtype=np.float64)
        normal = np.array([nx, ny, nz], dtype=np.float64)
        vel_a, vel_b = np.array(va, dtype=np.float64), np.array(vb, dtype=np.float64)
        inv_a = 0.0 if a.body is None else 1.0 / a.mass
        inv_b = 0.0 if b.body is None else 1.0 / b.mass
        j, j1 = pair_impulses(
            normal,
            vel_a,
            vel_b,
            inv_a,
            inv_b,
            a.spec.material.restitution,
            b.spec.material.restitution,
        )
        key = (a.spec.id, b.spec.id)
        if key in self._pending and self._pending[key].j_elastic >= float(j1):
            return
        self._pending[key] = Impact(
            step=self.step_index,
            time=self.time,
            body_a=a.spec.id,
            body_b=b.spec.id,
            point=point,
            normal=normal,
            depth=float(geom.depth),
            vel_a=vel_a,
            vel_b=vel_b,
            mass_a=a.mass,
            mass_b=b.mass,
            eps_a=a.spec.material.restitution,
            eps_b=b.spec.material.restitution,
            j=float(j),
            j_elastic=float(j1),
            pose_a=self.pose(a.spec.id),
            pose_b=self.pose(b.spec.id),
        )

    def _point_velocity(
        self, record: _Body, x: float, y: float, z: float
    ) -> tuple[float, float, float]:
        """Velocity of the body's material point at world (x, y, z), m/s."""
        if record.body is None:
            return (0.0, 0.0, 0.0)
        out = self._vel_buffer
        fast.point_vel(record.body_addr, x, y, z, self._vel_addr)
        return (out[0], out[1], out[2])

    # -- saving and resuming ---------------------------------------------------------------------
    def snapshot(self) -> WorldState:
        """Everything a resumed run needs to continue bit for bit: ODE's own state of each body
        (centre of mass, quaternion, velocities as stored), the order of the collision space
        (ODE moves geoms that moved to its front; collision order drives QuickStep), ODE's
        random seed (QuickStep's constraint order), the time and the step count."""
        bodies = {}
        for body_id, record in self.bodies.items():
            if record.body is None:
                continue
            b = record.body
            bodies[body_id] = (
                [ode.dBodyGetPosition(b)[i] for i in range(3)],
                [ode.dBodyGetQuaternion(b)[i] for i in range(4)],
                [ode.dBodyGetLinearVel(b)[i] for i in range(3)],
                [ode.dBodyGetAngularVel(b)[i] for i in range(3)],
            )
        by_geom = {_addr(r.geom): body_id for body_id, r in self.bodies.items()}
        order = [
            by_geom[_addr(ode.dSpaceGetGeom(self.space, i))]
            for i in range(ode.dSpaceGetNumGeoms(self.space))
        ]
        return WorldState(self.time, self.step_index, int(ode.dRandGetSeed()), order, bodies)

    def restore(self, state: WorldState) -> None:
        """Continue from `state` (same bodies, as `snapshot` listed them)."""
        missing = set(state.order) ^ set(self.bodies)
        if missing:
            raise ValueError(f"bodies differ from the saved world: {sorted(missing)}")
        for body_id, (pos, quat, lin, ang) in state.bodies.items():
            b = self.bodies[body_id].body
            ode.dBodySetPosition(b, *pos)
            ode.dBodySetQuaternion(b, (ode.dReal * 4)(*quat))
            # dBodySetQuaternion normalises again, which can move the last bit: store the saved
            # quaternion as it was and its rotation matrix as ODE's step makes it.
            q = ode.dBodyGetQuaternion(b)
            for i in range(4):
                q[i] = quat[i]
            fast.r_from_q(_addr(ode.dBodyGetRotation(b)), _addr(q))
            ode.dBodySetLinearVel(b, *lin)
            ode.dBodySetAngularVel(b, *ang)
        for body_id in reversed(state.order):  # each re-added geom goes to the space's front
            geom = self.bodies[body_id].geom
            ode.dSpaceRemove(self.space, geom)
            ode.dSpaceAdd(self.space, geom)
        ode.dRandSetSeed(state.seed)
        self.time = state.time
        self.step_index = state.step_index

    def close(self) -> None:
        for body_id in list(self.bodies):
            self.remove_body(body_id)
        ode.dJointGroupDestroy(self.contact_group)
        ode.dSpaceDestroy(self.space)
        ode.dWorldDestroy(self.world)
