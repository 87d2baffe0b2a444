"""The collision shape follows deep dents (issue 21, item 4), on the CPU and without reading a map.

Each dynamic body that takes dents keeps a proxy of its surface: points in body-local metres with
their outward normals and the body's thickness under them. A press moves the proxy's points the
way the carve moves texels (docs/carve.md, pass 4): inwards along their normal until they leave
the solid the tool sweeps, never deeper than the material's bound or the body's thickness. The
tool's solid is known in closed form as a signed distance (a sphere, capsule, box, plate or the
ground); a loaded mesh as a tool leaves the proxy alone. Once the deepest point has moved more
than RESHAPE_FRACTION of the body's size, the body's ODE geom becomes its mesh with the moved
points (physics/world.py `set_surface`): a ball flattened by a plate rests on its flat.

A trimesh of the dented surface, not its convex hull: the hull needs qhull (scipy, a dependency
of 40 MB for this alone), fills the pits a small ball leaves, and gained nothing in the tests
(the flattened ball rests on either).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dentdemo.carve.linear import determinant3
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.mesh.thickness import closed_thickness, vertex_thickness

#: A body's collision shape is rebuilt once its deepest dent passes this share of its size (the
#: radius of its bounding sphere about its local origin), and again each time it deepens by this
#: share more: deep dents only (a dented shape costs ODE a trimesh's contacts).
RESHAPE_FRACTION = 0.25

#: How finely a built-in shape's collision proxy is cut (ODE's trimesh contacts cost per
#: triangle: a sphere of 3 x 3 cells a cube face has 108 triangles).
COLLISION = Tessellation(sphere=3, around=12, rings=3)

#: Bisection steps for where a point leaves the tool's solid when that has no closed form here
#: (a capsule, a cylinder; a sphere, box, plate or the ground have one): the interval halves
#: each step, to 2^-30 of the depth bound.
_STEPS = 30

Field = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def proxy_for(shape: object, mesh: Mesh) -> DentProxy:
    """A body's fresh proxy: a built-in shape cut at COLLISION (a sphere scaled from one unit
    sphere, made once), a loaded mesh (`mesh`, the body's own) as it is."""
    from dentdemo.model.shapes import MeshFile, Sphere

    if isinstance(shape, MeshFile):
        return DentProxy.of(mesh)
    if isinstance(shape, Sphere):
        unit = _unit_proxy()
        return DentProxy(
            unit.points * shape.radius,
            unit.normals,
            unit.thickness * shape.radius,
            unit.triangles,
            unit.size * shape.radius,
        )
    return DentProxy.of(shape_mesh(shape, COLLISION))  # type: ignore[arg-type]


@functools.cache
def _unit_proxy() -> DentProxy:
    from dentdemo.model.shapes import Sphere

    return DentProxy.of(shape_mesh(Sphere(1.0), COLLISION))


class _Solid:
    """A convex solid's signed distance (a `Field`: world metres, < 0 inside) with `leave`,
    where a point moving along a line leaves it, in closed form (no bisection), and `framed`,
    the same solid in a body's frame."""

    def __call__(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        raise NotImplementedError

    def inside(self, p: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether each point lies inside (its distance < 0)."""
        return self(p) < 0.0

    def framed(self, rotation: NDArray[np.float64], origin: NDArray[np.float64]) -> _Solid:
        """The solid in the frame whose point x is the world point rotation @ x + origin
        (a rigid pose: `rotation` orthonormal), whose distances and exits are the same."""
        raise NotImplementedError

    def leave(self, p: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
        """For points `p` (k, 3) inside the solid moving along unit `d` (k, 3): the distance
        each goes before it leaves (the line's far crossing of the surface; inf: never)."""
        raise NotImplementedError


class _Sphere(_Solid):
    def __init__(self, centre: NDArray[np.float64], radius: float) -> None:
        self.centre, self.radius = np.asarray(centre, dtype=np.float64), float(radius)

    def __call__(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        v = p - self.centre
        return np.sqrt((v * v).sum(axis=1)) - self.radius  # np.linalg.norm's sum, fewer calls

    def framed(self, rotation: NDArray[np.float64], origin: NDArray[np.float64]) -> _Solid:
        return _Sphere((self.centre - origin) @ rotation, self.radius)

    def leave(self, p: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
        # |v + a d| = r, v = p - centre: a^2 + 2 a (v.d) + |v|^2 - r^2 = 0, the larger root.
        v = p - self.centre
        b = (v * d).sum(axis=1)
        c = (v * v).sum(axis=1) - self.radius**2
        return -b + np.sqrt(np.maximum(b * b - c, 0.0))


class _Box(_Solid):
    """The box of half extents `half` about `origin`, its axes the columns of `rotation`."""

    def __init__(
        self, rotation: NDArray[np.float64], origin: NDArray[np.float64], half: NDArray[np.float64]
    ) -> None:
        self.rotation, self.origin = rotation, origin
        self.half = np.asarray(half, dtype=np.float64)

    def framed(self, rotation: NDArray[np.float64], origin: NDArray[np.float64]) -> _Solid:
        # (R x + o - origin) @ Rb = (x - (origin - o) @ R) @ (R^T Rb)
        return _Box(rotation.T @ self.rotation, (self.origin - origin) @ rotation, self.half)

    def __call__(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        q = np.abs((p - self.origin) @ self.rotation) - self.half
        out = np.maximum(q, 0.0)
        outside = np.sqrt((out * out).sum(axis=1))  # np.linalg.norm's sum, fewer calls
        return outside + np.minimum(q.max(axis=1), 0.0)

    def inside(self, p: NDArray[np.float64]) -> NDArray[np.bool_]:
        # The distance is < 0 exactly where every axis is within its half extent.
        return (np.abs((p - self.origin) @ self.rotation) - self.half).max(axis=1) < 0.0

    def leave(self, p: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
        # In the box's frame, each pair of faces is left where q + a e = +-half along that axis
        # (the far face of each pair: +half moving up it, -half moving down); the point leaves
        # the box at the first of the three; never along an axis it does not move along.
        q, e = (p - self.origin) @ self.rotation, d @ self.rotation
        far = np.full(q.shape, np.inf)
        np.divide(np.where(e > 0, self.half, -self.half) - q, e, out=far, where=np.abs(e) >= 1e-300)
        return np.maximum(far.min(axis=1), 0.0)


class _Below(_Solid):
    """The half-space p . up < height (`up` unit): the ground's, below y = height, in the
    world; a tilted one in a body's frame."""

    def __init__(self, height: float, up: NDArray[np.float64] | None = None) -> None:
        self.height = float(height)
        self.up = np.array([0.0, 1.0, 0.0]) if up is None else np.asarray(up, dtype=np.float64)

    def __call__(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        return p @ self.up - self.height

    def framed(self, rotation: NDArray[np.float64], origin: NDArray[np.float64]) -> _Solid:
        # (R x + o) . up = x . (R^T up) + o . up
        return _Below(self.height - float(origin @ self.up), self.up @ rotation)

    def leave(self, p: NDArray[np.float64], d: NDArray[np.float64]) -> NDArray[np.float64]:
        rise = d @ self.up
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(rise > 0, np.maximum((self.height - p @ self.up) / rise, 0.0), np.inf)


def sphere_field(centre: NDArray[np.float64], radius: float) -> Field:
    """Signed distance to a sphere (world metres, < 0 inside)."""
    return _Sphere(centre, radius)


def capsule_field(a: NDArray[np.float64], b: NDArray[np.float64], radius: float) -> Field:
    """Signed distance to the sphere of `radius` swept from `a` to `b`."""
    axis = b - a
    length2 = float(axis @ axis)

    def field(p: NDArray[np.float64]) -> NDArray[np.float64]:
        t = np.clip(((p - a) @ axis) / length2, 0.0, 1.0) if length2 > 0 else np.zeros(len(p))
        return np.linalg.norm(p - (a + t[:, None] * axis), axis=1) - radius

    return field


def box_field(model: NDArray[np.float64], half: NDArray[np.float64]) -> Field:
    """Signed distance to a box of half extents `half` about the origin of `model` (world from
    local, a rotation and a translation)."""
    return _Box(model[:3, :3], model[:3, 3], half)


def ground_field(height: float) -> Field:
    """Signed distance to the half-space below y = `height`."""
    return _Below(height)


def cylinder_field(model: NDArray[np.float64], radius: float, length: float) -> Field:
    """Signed distance to a solid cylinder about local z (`length` long, centred) posed by
    `model` (a rotation and a translation)."""
    rotation, origin = model[:3, :3], model[:3, 3]

    def field(p: NDArray[np.float64]) -> NDArray[np.float64]:
        q = (p - origin) @ rotation
        d = np.stack([np.hypot(q[:, 0], q[:, 1]) - radius, np.abs(q[:, 2]) - length / 2], 1)
        return np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)

    return field


def shape_field(shape: object, model: NDArray[np.float64]) -> Field | None:
    """The solid of a scene shape posed by `model` at first touch (None: a loaded mesh, whose
    solid has no closed form here). Shapes as mesh/primitives.py and physics/geoms.py build
    them: capsules and cylinders along local z, a plate's top face at local y = 0."""
    from dentdemo.model.shapes import Box, Capsule, Cylinder, Plane, Plate, Sphere

    match shape:
        case Sphere(radius=r):
            return sphere_field(model[:3, 3], r)
        case Capsule(radius=r, length=length):
            ends = np.array([[0.0, 0.0, -length / 2, 1.0], [0.0, 0.0, length / 2, 1.0]])
            a, b = (ends @ model.T)[:, :3]
            return capsule_field(a, b, r)
        case Box(size=size):
            return box_field(model, np.asarray(size, dtype=np.float64) / 2)
        case Plate(side=side, thickness=thickness):
            centre = model.copy()
            centre[:3, 3] = model[:3, 3] - model[:3, 1] * thickness / 2  # below the top face
            return box_field(centre, np.array([side / 2, thickness / 2, side / 2]))
        case Cylinder(radius=r, length=length):
            return cylinder_field(model, r, length)
        case Plane():
            return ground_field(float(model[1, 3]))
    return None


def _rigid(linear: NDArray[np.float64]) -> bool:
    """Whether a pose's linear part is a rotation (orthonormal and not mirrored, to 1e-9); on
    Python floats (nine numbers)."""
    m = linear.tolist()
    for r in range(3):
        for c in range(r, 3):
            dot = m[0][r] * m[0][c] + m[1][r] * m[1][c] + m[2][r] * m[2][c]
            if abs(dot - (1.0 if r == c else 0.0)) >= 1e-9:
                return False
    return determinant3(linear) > 0.0


@dataclass
class DentProxy:
    """A dynamic body's surface points and how far each has been pressed in (metres)."""

    points: NDArray[np.float64]  # (n, 3) body-local metres: the body's mesh's vertices
    normals: NDArray[np.float64]  # (n, 3) unit, outward
    #: (n,) metres (mesh/thickness.py); NaN where not yet known: ray cast from `source` for
    #: the points a press reaches (a loaded mesh has no closed form).
    thickness: NDArray[np.float64]
    triangles: NDArray[np.int64]  # (m, 3) the mesh's, wound outwards
    size: float  # bounding radius about the local origin, metres
    inward: NDArray[np.float64] = field(init=False)
    #: `inward` when the geom was last rebuilt: what the collision shape holds.
    shaped: NDArray[np.float64] = field(init=False)
    #: The deepest point's depth when the geom was last rebuilt (0: never), metres.
    rebuilt_at: float = 0.0
    #: The mesh whose vertices `points` are, where `thickness` is still to be ray cast.
    source: Mesh | None = None

    def __post_init__(self) -> None:
        self.inward = np.zeros(len(self.points))
        self.shaped = np.zeros(len(self.points))
        length = np.linalg.norm(self.normals, axis=1, keepdims=True)
        #: `normals` of length 1 (the way a press moves each point).
        self._unit = self.normals / np.maximum(length, 1e-30)

    @classmethod
    def of(cls, mesh: Mesh) -> DentProxy:
        normals = mesh.normals.astype(np.float64)
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
        closed = closed_thickness(mesh)
        unknown = np.full(len(mesh.positions), np.nan)
        return cls(
            mesh.positions.astype(np.float64),
            normals,
            unknown if closed is None else closed.astype(np.float64),
            mesh.indices.astype(np.int64),
            mesh.bounding_radius,
            source=None if closed is not None else mesh,
        )

    @property
    def deepest(self) -> float:
        return float(self.inward.max()) if len(self.inward) else 0.0

    def press(
        self,
        model: NDArray[np.float64],
        tool: Field,
        direction: NDArray[np.float64],
        advance: float,
        max_depth: float,
    ) -> None:
        """The body posed by `model` (world from local) at first touch, pressed by the solid
        `tool` moved `advance` metres along `direction` (unit, world): each point inside it moves
        inwards along its normal until it leaves it, at most `max_depth` or the body's thickness
        under it; dents only deepen."""
        linear, origin = model[:3, :3], model[:3, 3]
        shift = np.asarray(direction, dtype=np.float64) * advance
        if isinstance(tool, _Solid) and _rigid(linear):
            # In the body's frame: its points and normals as they are, the tool and the shift
            # turned into it (a rigid pose keeps distances and exits), not every point moved
            # into the world.
            moved = self.points - shift @ linear
            self._pressed(moved, self._unit, tool.framed(linear, origin), max_depth)
            return
        normal = self.normals @ linear.T
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
        self._pressed(self.points @ linear.T + origin - shift, normal, tool, max_depth)

    def _pressed(
        self,
        moved: NDArray[np.float64],
        normal: NDArray[np.float64],
        tool: Field,
        max_depth: float,
    ) -> None:
        """`press` in one frame: `moved` the points less the tool's advance, `normal` their
        unit normals, `tool` the solid, all in that frame."""
        start = moved - self.inward[:, None] * normal
        k = np.nonzero(tool.inside(start) if isinstance(tool, _Solid) else tool(start) < 0.0)[0]
        if len(k) == 0:
            return
        unknown = k[np.isnan(self.thickness[k])]
        if len(unknown) and self.source is not None:
            self.thickness[unknown] = vertex_thickness(self.source, unknown)
        bound = np.minimum(max_depth, self.thickness[k])
        p, n = moved[k], normal[k]
        if isinstance(tool, _Solid):  # convex, in closed form: where the line leaves it
            leaves = tool.leave(p, -n)
            self.inward[k] = np.maximum(self.inward[k], np.minimum(leaves, bound))
            return

        def inside(a: NDArray[np.float64]) -> NDArray[np.bool_]:
            return tool(p - a[:, None] * n) < 0.0

        lo, hi = self.inward[k].copy(), bound.copy()
        still = inside(hi)  # past the bound and still inside: the bound
        for _ in range(_STEPS):
            mid = 0.5 * (lo + hi)
            deeper = inside(mid)
            lo = np.where(deeper, mid, lo)
            hi = np.where(deeper, hi, mid)
        self.inward[k] = np.maximum(self.inward[k], np.where(still, bound, hi))

    def due(self) -> bool:
        """Whether the geom should be rebuilt now (see RESHAPE_FRACTION)."""
        return self.deepest > self.rebuilt_at + RESHAPE_FRACTION * self.size

    def rebuilt(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """Mark the geom rebuilt from the points as they are now; returns that surface."""
        self.shaped = self.inward.copy()
        self.rebuilt_at = self.deepest
        return self.surface()

    def surface(self) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The surface the collision shape holds (the points as of the last rebuild):
        (vertices (n, 3), triangles (m, 3)), body-local metres, wound outwards (the mesh's
        triangles over the moved points)."""
        return self.points - self.shaped[:, None] * self.normals, self.triangles
