"""The Simulation: physics -> material model -> carve, one object shared by the window and the
headless renderer. It owns the bodies' meshes and maps on the GPU and never reads them back."""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, replace
from pathlib import Path

import moderngl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from dentdemo.app.compact import CompactSaves
from dentdemo.app.hitlog import HitRecorder
from dentdemo.app.proxies import CollisionProxies
from dentdemo.app.shared import Shared
from dentdemo.app.stats import DentStats, SimStats
from dentdemo.app.wear import WearTracker
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver, CarverOptions, Press
from dentdemo.carve.surface import create_maps, load_height_png, map_size_for
from dentdemo.carve.undo import UndoLog, restore_pristine
from dentdemo.gl.context import GLContext
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.mesh import Mesh
from dentdemo.mesh.shapes import shape_mesh
from dentdemo.model.impulse import dent_depth
from dentdemo.model.materials import MaterialLibrary
from dentdemo.model.scene import BodySpec, Scene
from dentdemo.model.shapes import Plane, Shape, Sphere
from dentdemo.physics.simulate import build_world
from dentdemo.physics.world import Impact, PhysicsWorld, pose_matrix

#: How many recent carve points the contact debug view keeps.
CARVED_POINTS_KEPT = 1024


@dataclass
class SimBody:
    """A body of the world: the scene spec, its mesh (on the GPU too: the carve draws it) and its
    maps. What only the renderer uses is app/scenery.py's."""

    spec: BodySpec
    mesh: Mesh
    gpu_mesh: GpuMesh
    #: A body that takes no dents gets a flat 16^2 stand-in: it can still dent others.
    maps: SurfaceMaps


@dataclass(frozen=True)
class CarveRequest:
    """One impact waiting for the carve: poses at first touch and both depths (m)."""

    impact: Impact
    depth_a: float
    depth_b: float
    model_a: NDArray[np.float64]
    model_b: NDArray[np.float64]

    def deepest(self) -> tuple[str, float]:
        """The body with the deeper dent and that depth, metres."""
        if self.depth_a >= self.depth_b:
            return self.impact.body_a, self.depth_a
        return self.impact.body_b, self.depth_b


def map_side(spec: BodySpec, mesh: Mesh) -> int:
    """Side of a body's square maps, texels: a body that takes no dents gets a 16² stand-in."""
    return map_size_for(mesh, spec.texels_per_metre) if spec.dentable else 16


class Simulation:
    """Steps physics at the scene's fixed dt, turns impacts into dents, keeps the render state."""

    def __init__(
        self,
        gl: GLContext,
        scene: Scene,
        materials: MaterialLibrary,
        *,
        denting: bool = True,
        carve_budget: int = 16,
    ) -> None:
        self.gl = gl
        self.scene = scene
        self.materials = materials
        #: False: impacts are still detected, nothing is carved.
        self.denting = denting
        #: Most carves per frame; the rest wait in `queue` for later frames (none is dropped).
        self.carve_budget = carve_budget
        self.time_scale = 1.0
        #: Each carved batch (one frame's queue) snapshotted on the GPU for undo (carve/undo.py);
        #: not saved with the state: a reset or a load empties it.
        self.undo_log = UndoLog(gl)
        # The sandbox owns its context, and its renderer and panel set the state each of their
        # passes draws with: no host state to give back after each frame's carve.
        self.carver = Carver(gl, CarverOptions(keep_host_state=False, undo_log=self.undo_log))
        self.queue: deque[CarveRequest] = deque()
        self.stats = SimStats()
        self.last_impacts: list[Impact] = []
        #: Where the most recent carves were, world metres (the contact debug view).
        self.carved_points: deque[NDArray[np.float64]] = deque(maxlen=CARVED_POINTS_KEPT)
        #: The most recent carve (the close-up camera frames it), None before the first.
        self.last_hit: CarveRequest | None = None
        self.ball_count = 0
        self._time_debt = 0.0
        #: Per body: how many dents and the deepest press (the panel's selection).
        self.dents: dict[str, DentStats] = {}
        #: Per dynamic body that took a dent: its surface as pressed (its collision shape),
        #: with each carved batch's undo record (app/proxies.py).
        self.proxies = CollisionProxies()
        #: Per shape, the mesh (its query structures built, not at a body's first hit) and its
        #: GPU buffers that every body of that shape draws with: a body's first carve finds
        #: the vertex arrays and index streams the bodies before it made.
        self._meshes: Shared[Shape, tuple[Mesh, GpuMesh]] = Shared(self._make_mesh, _release_mesh)
        self.bodies: dict[str, SimBody] = {}
        #: Added by HitRecorder.attach (a --hit-log, compact saves): every carve, and what else
        #: changes the maps, as records.
        self.recorders: list[HitRecorder] = []
        #: Set by app/state.py's enable_compact_saves: saves hold a checkpoint and a hit log.
        self.compact_saves: CompactSaves | None = None
        self.world: PhysicsWorld = build_world(scene)
        #: Scratches (app/wear.py), where the scene's physics wears (wear_scale > 0).
        self.wear = WearTracker(gl, scene.physics.wear_scale) if scene.physics.wear_scale else None
        for spec in scene.bodies:
            self._add_render_body(spec)

    # -- bodies --------------------------------------------------------------------------------
    def _add_render_body(self, spec: BodySpec) -> SimBody:
        mesh, gpu = self._meshes.take(spec.shape)
        size = map_side(spec, mesh)
        start = None
        if spec.dentable and spec.bump_map:
            start = load_height_png(Path(spec.bump_map), size, spec.bump_height)
        maps = create_maps(self.gl, gpu, size, spec.material.max_dent_depth, start)
        self.carver.warm(gpu, maps)  # its shader variants compiled now, not in a carve's frame
        body = SimBody(spec, mesh, gpu, maps)
        self.bodies[spec.id] = body
        return body

    def _make_mesh(self, shape: Shape) -> tuple[Mesh, GpuMesh]:
        mesh = shape_mesh(shape)
        mesh.prepare_queries()  # not at the body's first hit (a carve's frame)
        gpu = GpuMesh(self.gl, mesh)
        self.carver.prepare(gpu)  # nor its vertex arrays and index streams
        return mesh, gpu

    def _release_body(self, body: SimBody) -> None:
        """The body's maps deleted, and its mesh's buffers once no other body draws them."""
        body.maps.release()
        self._meshes.give_back(body.spec.shape)

    def drop_ball(
        self,
        position: ArrayLike,
        velocity: ArrayLike = (0.0, 0.0, 0.0),
        material: str = "steel",
        radius: float = 0.04,
        texels_per_metre: float = 1024.0,
    ) -> str:
        """Add a ball (the demo's click and throw); returns its id."""
        if not (math.isfinite(radius) and radius > 0):
            raise ValueError(f"ball radius must be positive, got {radius}")
        self.ball_count += 1
        body_id = f"ball_{self.ball_count}"
        while body_id in self.bodies:
            self.ball_count += 1
            body_id = f"ball_{self.ball_count}"
        spec = BodySpec(
            id=body_id,
            shape=Sphere(radius),
            material=self.materials.get(material),
            position=_triple(position),
            velocity=_triple(velocity),
            texels_per_metre=texels_per_metre,
        )
        self.add_body(spec)
        return body_id

    def add_body(self, spec: BodySpec) -> None:
        """Add a body while running: to the physics world and, with its maps, to the GPU."""
        self.world.add_body(spec)
        self._add_render_body(spec)
        for recorder in self.recorders:
            recorder.added(spec.id)

    def remove_body(self, body_id: str) -> None:
        self.world.remove_body(body_id)
        self._drop_body(body_id)
        self.queue = deque(
            r for r in self.queue if body_id not in (r.impact.body_a, r.impact.body_b)
        )

    def set_materials(self, materials: MaterialLibrary, source: str = "materials") -> None:
        """Use `materials` from now on (a hot reload): every body, the scene's included, takes
        its preset's new values by name (looks, friction, restitution, density, k, Y, the dent
        bound for new dents); new balls and plates use them too. Poses, velocities and dents are
        kept. A preset that a body uses and `materials` lacks raises a ConfigError naming
        `source`, and nothing changes."""
        for spec in [*self.scene.bodies, *(b.spec for b in self.bodies.values())]:
            materials.get(spec.material.name, source, f"body '{spec.id}'")

        def renewed(spec: BodySpec) -> BodySpec:
            material = materials.materials[spec.material.name]
            return spec if material == spec.material else replace(spec, material=material)

        self.materials = materials
        self.scene = replace(self.scene, bodies=tuple(map(renewed, self.scene.bodies)))
        for body_id, body in self.bodies.items():
            spec = renewed(body.spec)
            if spec is body.spec:
                continue
            body.spec = spec
            if body.maps.max_dent_depth != spec.material.max_dent_depth:
                for recorder in self.recorders:
                    recorder.event(self, "depth_bound", body_id, spec.material.max_dent_depth)
            body.maps.max_dent_depth = spec.material.max_dent_depth
            if body_id in self.world.bodies:
                self.world.set_spec(spec)

    def draw_every_address(self, on: bool) -> None:
        """Whether the carve draws pass 2 for every target (the address-map debug view) or only
        where pass 4 needs it: a carver made with that option replaces the one before (their
        options are fixed), its shader variants compiled as the next carves draw them."""
        if self.carver.options.address_every_target != on:
            old = self.carver
            self.carver = Carver(self.gl, replace(old.options, address_every_target=on))
            old.release()

    def address_map(self) -> tuple[moderngl.Texture, tuple[int, int]] | None:
        """The last carve's address map and its size in pixels (the address-map debug view),
        or None before the first carve."""
        if not self.carver.last_jobs:
            return None
        resolution = self.carver.last_jobs[0].camera.resolution
        return self.carver.address_texture(), (resolution[0], resolution[1])

    def model(self, body_id: str) -> NDArray[np.float64]:
        return self.world.model_matrix(body_id) if body_id in self.world.bodies else np.eye(4)

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> list[Impact]:
        """One fixed physics step, then up to `carve_budget` carves from the queue."""
        start = time.perf_counter()
        impacts = self.world.step()
        for gone in self.world.removed:
            if gone in self.bodies:
                self._drop_body(gone)
        self.world.removed.clear()
        physics_ms = (time.perf_counter() - start) * 1e3
        self.last_impacts = impacts
        self.stats.impacts += len(impacts)
        if self.denting:
            for impact in impacts:
                request = self._request(impact)
                if request is not None:
                    self.queue.append(request)
            if self.wear is not None:
                self.wear.observe(self, self.world.slides)
        start = time.perf_counter()
        done = self.apply_queued(self.carve_budget)
        carve_ms = (time.perf_counter() - start) * 1e3
        self.stats.frames += 1
        self.stats.hits += done
        self.stats.physics_ms = physics_ms
        self.stats.carve_ms = carve_ms
        if done:
            self.stats.carve_ms_per_hit = carve_ms / done
        return impacts

    def apply_queued(self, limit: int | None = None) -> int:
        """Carve up to `limit` queued impacts (all without a limit), oldest first; returns how many.
        No physics step: what the budget deferred lands on the current state."""
        taken: list[CarveRequest] = []
        while self.queue and (limit is None or len(taken) < limit):
            taken.append(self.queue.popleft())
        presses = [press for press in map(self._press, taken) if press is not None]
        grooves = self.wear.take(self) if self.wear is not None else []
        if presses or grooves:

            def follow() -> None:  # no GL call: the carve runs it while its gathers are drawn
                for request, _ in presses:
                    for body_id, depth in (
                        (request.impact.body_a, request.depth_a),
                        (request.impact.body_b, request.depth_b),
                    ):
                        if depth > 0.0:
                            self.dents.setdefault(body_id, DentStats()).add(depth)
                        self.proxies.note(body_id)  # as it was, for undo
                    self._follow_dents(request)

            # One batch: every hit reads the heights from before it (docs/carve.md, "Batches").
            self.carver.carve_many(
                [press for _, press in presses] + grooves, meanwhile=follow, meanwhile_uses_gl=False
            )
            carved = self.wear.taken if grooves and self.wear is not None else []
            for recorder in self.recorders:
                recorder.batch(self, [request for request, _ in presses], carved)
            self.carved_points.extend(request.impact.point for request, _ in presses)
            self.carved_points.extend(groove.contact.point for groove in grooves)
            if presses:
                self.last_hit = presses[-1][0]
            self.proxies.close_batch(kept=len(self.undo_log) > 0)
        return len(taken)

    def _follow_dents(self, request: CarveRequest) -> None:
        """Press the collision proxies of the request's bodies (app/proxies.py)."""
        self.proxies.press(request, self.bodies, self.world)

    def advance(self, seconds: float, max_steps: int = 4) -> int:
        """Steps owed for `seconds` of wall time times the time scale (window use)."""
        self._time_debt += seconds * self.time_scale
        steps = 0
        while self._time_debt >= self.scene.physics.dt and steps < max_steps:
            self.step()
            self._time_debt -= self.scene.physics.dt
            steps += 1
        if steps == max_steps:
            self._time_debt = 0.0
        return steps

    def _request(self, impact: Impact) -> CarveRequest | None:
        a, b = self.bodies.get(impact.body_a), self.bodies.get(impact.body_b)
        if a is None or b is None:
            return None
        ma, mb = a.spec.material, b.spec.material
        depth_a = (
            float(dent_depth(impact.j_elastic, ma.k, ma.Y, ma.max_dent_depth))
            if a.spec.dentable
            else 0.0
        )
        depth_b = (
            float(dent_depth(impact.j_elastic, mb.k, mb.Y, mb.max_dent_depth))
            if b.spec.dentable
            else 0.0
        )
        if depth_a <= 0.0 and depth_b <= 0.0:
            return None  # no GPU work for an impact below both thresholds
        model_a = pose_matrix(*impact.pose_a)
        if isinstance(a.spec.shape, Plane):
            model_a[:3, 3] = [impact.point[0], a.spec.position[1], impact.point[2]]
        model_b = pose_matrix(*impact.pose_b)
        model_b[:3, 3] += impact.normal * impact.depth  # undo the penetration: first touch
        return CarveRequest(impact, depth_a, depth_b, model_a, model_b)

    def _press(self, request: CarveRequest) -> tuple[CarveRequest, Press] | None:
        """A queued impact as a press for the carver (None: one of its bodies is gone)."""
        impact = request.impact
        a, b = self.bodies.get(impact.body_a), self.bodies.get(impact.body_b)
        if a is None or b is None:
            return None
        target = CarveBody(a.gpu_mesh, a.maps, request.model_a)
        tool = CarveBody(b.gpu_mesh, b.maps, request.model_b)
        # B moves into A along -N; the carve finds the surface point of A nearest to the contact.
        contact = ContactFrame(impact.point, -impact.normal)
        return request, Press(target, tool, contact, request.depth_a, request.depth_b)

    def _drop_body(self, body_id: str) -> None:
        if self.wear is not None:
            self.wear.forget(body_id)
        self.dents.pop(body_id, None)
        self.proxies.forget(body_id)
        body = self.bodies.pop(body_id)
        self.undo_log.forget(body.maps)
        self._release_body(body)

    # -- undo and repair -----------------------------------------------------------------------
    def undo(self) -> bool:
        """Take back the last carved batch (one frame's hits, both bodies of each, bit for bit)
        from the GPU snapshots, and the collision shapes it pressed (app/reshape.py); False when
        none is left (see carve/undo.py for the bounds)."""
        if not self.undo_log.undo():
            return False
        for recorder in self.recorders:
            recorder.event(self, "undo")
        self.proxies.undo(self.bodies, self.world)
        return True

    def repair(self, body_id: str) -> None:
        """Give a body back its pristine maps (height 0, or its scene bump map, and their
        normals); its part of the undo history is dropped."""
        body = self.bodies[body_id]
        for recorder in self.recorders:
            recorder.event(self, "repair", body_id)
        start = None
        if body.spec.dentable and body.spec.bump_map:
            size = body.maps.size[0]
            start = load_height_png(Path(body.spec.bump_map), size, body.spec.bump_height)
        self.undo_log.forget(body.maps)
        restore_pristine(self.gl, body.gpu_mesh, body.maps, start)
        if self.proxies.forget(body_id):
            self.world.reset_shape(body_id)  # its collision shape is the pristine one again

    # -- lifecycle -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the scene as loaded: bodies, poses and pristine maps (no undo history)."""
        self.undo_log.clear()
        self._release_bodies()
        self.world.close()
        self.bodies.clear()
        self.queue.clear()
        self.carved_points.clear()
        self.last_hit = None
        self.dents.clear()
        self.proxies.clear()
        if self.wear is not None:
            self.wear.clear()
        self.stats = SimStats()
        self.ball_count = 0
        self._time_debt = 0.0
        self.world = build_world(self.scene)
        for recorder in self.recorders:
            recorder.event(self, "reset")
        for spec in self.scene.bodies:
            self._add_render_body(spec)

    def _release_bodies(self) -> None:
        for body in self.bodies.values():
            self._release_body(body)

    def close(self) -> None:
        self.undo_log.release()
        self._release_bodies()
        if self.wear is not None:
            self.wear.release()
        self.carver.release()
        self.world.close()


def _triple(vector: ArrayLike) -> tuple[float, float, float]:
    """Three numbers (a position or velocity, world metres or m/s) as plain floats."""
    x, y, z = np.asarray(vector, dtype=np.float64).reshape(3)
    return float(x), float(y), float(z)


def _release_mesh(held: tuple[Mesh, GpuMesh]) -> None:
    held[1].release()
