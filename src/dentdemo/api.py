"""The types a host program needs to carve dents in its own moderngl context (re-exported by
`dentdemo`). Every call here leaves the host's GL state as it found it. A bad argument raises
ValueError (dentdemo.errors.ArgumentError) naming the argument and its value. A call made where
its objects' GL context is not current in the calling thread (another context is current, or
none is: another thread) raises dentdemo.errors.ContextError (a RuntimeError) before any work:
dentdemo never switches contexts, so the host keeps the current context it had."""

from __future__ import annotations

import functools
import math
import numbers
import os
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar, cast

import moderngl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from dentdemo.api_hitlog import SurfaceRecorder
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, CarverOptions, Press
from dentdemo.carve.carver import Carver as _Carver
from dentdemo.carve.surface import (
    MAX_MAP_SIZE,
    MIN_MAP_SIZE,
    create_maps,
    load_height_png,
    rebuild_all_normals,
)
from dentdemo.carve.undo import UndoLog, restore_pristine
from dentdemo.errors import ArgumentError, ConfigError, DentdemoError
from dentdemo.gl.context import GLContext, per_context
from dentdemo.gl.state import preserved
from dentdemo.gpu.maps import SurfaceMaps
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.mesh import Mesh
from dentdemo.model import hitlog
from dentdemo.model.hitlog import Body, Event, Hit, HitLogError, Record
from dentdemo.model.materials import SURFACES, Appearance, MaterialLibrary
from dentdemo.model.materials_keys import NUMBER_KEYS


def _vector(name: str, value: object) -> NDArray[np.float64]:
    """`value` as 3 finite float64 numbers, or an error naming `name` and the value."""
    try:
        data = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        data = np.zeros(0)
    if data.shape != (3,) or not np.isfinite(data).all():
        raise ArgumentError(f"{name} must be 3 finite numbers (x, y, z), got {value!r}")
    return data


def _real(name: str, value: object, what: str) -> float:
    """`value` as a finite float >= 0, or an error naming `name`, the value and `what` it is."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        number = float(value)
        if math.isfinite(number) and number >= 0:
            return number
    raise ArgumentError(f"{name} must be {what}, got {value!r}")


def _pose(name: str, value: object) -> NDArray[np.float64]:
    """`value` as a 4x4 float64 pose (world from local, metres): finite, affine (last row
    0 0 0 1), its 3x3 part invertible and not mirroring (a mirror turns the faces inside out).
    Checked on Python floats: press() checks both poses, and numpy's calls cost microseconds
    each on 16 numbers."""
    try:
        m = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        m = np.zeros(0)
    if m.shape != (4, 4):
        shown = f"shape {m.shape}" if m.size else repr(value)
        raise ArgumentError(f"{name} must be a 4x4 matrix (world from local, metres), got {shown}")
    (a, b, c, _), (d, e, f, _), (g, h, i, _), last = rows = m.tolist()
    # A NaN or infinity anywhere makes the sum so (as may finite values near 1e308).
    if not math.isfinite(sum(map(sum, rows))) and not np.isfinite(m).all():
        row, col = (int(k) for k in np.argwhere(~np.isfinite(m))[0])
        raise ArgumentError(f"{name} must be finite, got {m[row, col]} at row {row}, column {col}")
    if max(abs(x - y) for x, y in zip(last, (0.0, 0.0, 0.0, 1.0), strict=True)) > 1e-9:
        raise ArgumentError(f"{name} must be affine (last row 0 0 0 1), got {last}")
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if not det > 1e-18:
        raise ArgumentError(
            f"{name} must not flatten or mirror the mesh: its 3x3 part has determinant {det:g} "
            "(mirror the vertices instead)"
        )
    return m


def _map_size(value: object) -> int:
    whole = isinstance(value, numbers.Integral) and not isinstance(value, bool)
    if not (whole and MIN_MAP_SIZE <= int(value) <= MAX_MAP_SIZE):  # type: ignore[call-overload]
        raise ArgumentError(
            f"map_size must be a whole number of texels from {MIN_MAP_SIZE} to {MAX_MAP_SIZE} "
            f"(the largest map), got {value!r}"
        )
    return int(value)  # type: ignore[call-overload]


def _as_mesh(mesh: object) -> Mesh:
    """A Mesh as is; a trimesh.Trimesh converted (its texture coordinates kept where they are a
    unique atlas, as load_mesh does)."""
    if isinstance(mesh, Mesh):
        return mesh
    trimesh = sys.modules.get("trimesh")  # a Trimesh comes with its module already imported
    if trimesh is not None and isinstance(mesh, trimesh.Trimesh):
        from dentdemo.mesh.loader import mesh_from_trimesh

        return mesh_from_trimesh(mesh, name=str(mesh.metadata.get("name") or "trimesh mesh"))
    if trimesh is not None and isinstance(mesh, trimesh.Scene):
        raise ArgumentError(
            f"mesh must be one mesh, got a trimesh.Scene of {len(mesh.geometry)} geometries: "
            "pass scene.to_geometry(), or load the file with dentdemo.load_mesh"
        )
    raise ArgumentError(
        f"mesh must be a dentdemo.Mesh or a trimesh.Trimesh, got {type(mesh).__name__}"
    )


_Method = TypeVar("_Method", bound=Callable[..., Any])


def _in_context(method: _Method) -> _Method:
    """`method` of a surface or carver, run only where the object's GL context is current in
    the calling thread: ContextError naming the call first, before any work."""
    call = f"{method.__name__}()"

    @functools.wraps(method)
    def checked(self: DentableSurface | Carver, *args: Any, **kwargs: Any) -> Any:
        self._context().check_current(call)
        return method(self, *args, **kwargs)

    return cast(_Method, checked)


class Contact:
    """Where and which way a press goes: `point` on the target's surface at first touch (world
    metres) and `direction` (world, any non-zero length), the way the tool moves into the
    target. Both are checked when set: 3 finite numbers each."""

    __slots__ = ("_point", "_direction")

    def __init__(self, point: ArrayLike, direction: ArrayLike) -> None:
        self.point = point
        self.direction = direction

    @property
    def point(self) -> NDArray[np.float64]:
        return self._point

    @point.setter
    def point(self, value: ArrayLike) -> None:
        self._point = _vector("Contact point", value)

    @property
    def direction(self) -> NDArray[np.float64]:
        return self._direction

    @direction.setter
    def direction(self, value: ArrayLike) -> None:
        direction = _vector("Contact direction", value)
        if not float(np.linalg.norm(direction)) > 1e-12:
            raise ArgumentError(f"Contact direction must not be zero, got {value!r}")
        self._direction = direction


def _wrap(ctx: moderngl.Context) -> GLContext:
    """dentdemo's wrapper of a host context, made once per context (it caches programs); kept
    beside the context, never in the host's `ctx.extra`."""
    store = per_context(ctx)
    if "host" not in store:
        store["host"] = GLContext(ctx=ctx, backend="host")
    return store["host"]


def _alive(ctx: moderngl.Context) -> bool:
    """Whether `ctx` is not yet released (a released one took its objects with it)."""
    return not isinstance(ctx.mglo, moderngl.InvalidObject)


def _undo_log(ctx: moderngl.Context, make: bool = True) -> UndoLog | None:
    """The undo log of a host context, shared by its Carvers (made by the first one)."""
    store = per_context(ctx)
    if "undo" not in store and make:
        with preserved(ctx):
            store["undo"] = UndoLog(_wrap(ctx))
    return store.get("undo")


class DentableSurface:
    """A mesh that takes dents: its triangles on the GPU and its maps, `map_size` texels a side
    (16 to 4096).

    `height` (R32F, metres along the surface normal, < 0 in a dent, never below
    -max_dent_depth) and `normal` (RGBA8, tangent space, xyz * 0.5 + 0.5, in the frame of
    `Mesh.tangents`: T along +u, B = cross(N, T) * w; sample with the mesh's uv, row 0 at
    v = 0) are textures to bind in the host's shaders. `model` is the pose (4x4, world from
    local, metres; checked when set). The mesh is never changed; `mesh` (a Mesh, or a
    trimesh.Trimesh, converted) keeps its own texture coordinates where they are a unique atlas
    and is re-atlased otherwise: `surface.mesh` is what to draw, and its `source_vertex` maps
    its vertices to the ones given. After `release()` every method raises ValueError.
    `Carver.repair` puts back the maps the surface was made with (flat, or the heights last
    given to `set_heights` or `set_bump_map`).
    """

    __slots__ = ("_gl", "_mesh", "_model", "_gpu", "_maps", "_start")

    def __init__(
        self,
        ctx: moderngl.Context,
        mesh: Mesh,
        map_size: int = 1024,
        max_dent_depth: float = 0.01,
        model: NDArray[np.float64] | None = None,
    ) -> None:
        if not isinstance(ctx, moderngl.Context):
            raise ArgumentError(f"ctx must be a moderngl.Context, got {type(ctx).__name__}")
        size = _map_size(map_size)
        deepest = _real("max_dent_depth", max_dent_depth, "a finite number of metres > 0")
        if deepest == 0:
            raise ArgumentError(f"max_dent_depth must be > 0 metres, got {max_dent_depth!r}")
        self.model = np.eye(4) if model is None else model
        self._mesh = _as_mesh(mesh)
        self._mesh.prepare_queries()  # not at the surface's first press
        self._gl = _wrap(ctx)
        self._gl.check_current("DentableSurface()")
        with preserved(ctx):
            self._gpu: GpuMesh | None = GpuMesh(self._gl, self._mesh)
            self._maps: SurfaceMaps | None = create_maps(self._gl, self._gpu, size, deepest)
        #: The heights `repair` puts back, float32 [v, u] metres as written (None: all 0).
        self._start: NDArray[np.float32] | None = None

    @property
    def mesh(self) -> Mesh:
        return self._mesh

    @property
    def model(self) -> NDArray[np.float64]:
        return self._model

    @model.setter
    def model(self, value: ArrayLike) -> None:
        self._model = _pose("model", value)

    @property
    def map_size(self) -> int:
        return self._live("map_size").size[0]

    @property
    def max_dent_depth(self) -> float:
        return self._live("max_dent_depth").max_dent_depth

    @property
    def height(self) -> moderngl.Texture:
        return self._live("height").height

    @property
    def normal(self) -> moderngl.Texture:
        return self._live("normal").normal

    @_in_context
    def heights(self) -> NDArray[np.float32]:
        """The height map read back to the CPU, float32 [v, u] metres (for saving with
        numpy.save and inspection; a frame loop binds `height` instead)."""
        maps = self._live("heights()")
        with preserved(self._gl.ctx):
            return self._gl.read(maps.height)[:, :, 0]

    @_in_context
    def set_heights(self, heights: ArrayLike | str | os.PathLike) -> None:
        """Replace the height map and rebuild the normals on the GPU. `heights` is a float
        [v, u] array in metres, map_size x map_size (what `heights()` returns), or the path of
        a .npy file holding one (what `heights()` saved, or `dentdemo render --maps-dir`
        wrote). Values must be finite; a value below -max_dent_depth is an error (the map never
        holds one), positive values are bumps."""
        maps = self._live("set_heights()")
        if isinstance(heights, str | os.PathLike):
            heights = _read_npy(Path(heights))
        data = np.asarray(heights)
        side = maps.size[0]
        if data.dtype.kind != "f" or data.shape != (side, side):
            raise ArgumentError(
                f"heights must be a float [v, u] array of shape {(side, side)} (map_size), "
                f"got {data.dtype} of shape {data.shape}"
            )
        self._write_heights(data.astype(np.float32))

    @_in_context
    def set_bump_map(self, path: str | os.PathLike, white_height: float) -> None:
        """Start from a bump map: a greyscale image (8- or 16-bit PNG; colour counts by its
        luminance) laid over the atlas as heights, white = `white_height` metres, black = 0,
        resized to the map (image top row at v = 1). Replaces the heights; rebuilds the
        normals."""
        maps = self._live("set_bump_map()")
        amplitude = _real("white_height", white_height, "a finite number of metres >= 0")
        try:
            data = load_height_png(Path(path), maps.size[0], amplitude)
        except DentdemoError as exc:
            raise ArgumentError(str(exc)) from None
        self._write_heights(data)

    def release(self) -> None:
        """Free the GPU buffers and maps (again, or once the context is released: nothing on
        the GPU); their undo snapshots go too."""
        if self._maps is not None and self._gpu is not None and _alive(self._gl.ctx):
            self._gl.check_current("release()")
            self._forget_undo(self._maps)
            self._maps.release()
            self._gpu.release()
        self._maps = self._gpu = None

    def _context(self) -> GLContext:
        return self._gl

    def _live(self, what: str) -> SurfaceMaps:
        """The maps, or a clear error naming `what` needed them once released."""
        if self._maps is None:
            raise ArgumentError(
                f"{what}: this DentableSurface (mesh {self._mesh.name!r}) was released; "
                "make a new one"
            )
        return self._maps

    def _write_heights(self, data: NDArray[np.float32]) -> None:
        maps = self._live("set_heights()")
        if not np.isfinite(data).all():
            count = int((~np.isfinite(data)).sum())
            raise ArgumentError(f"heights must be finite, got {count} NaN or infinite values")
        lowest = float(data.min())
        # The map holds float32; a bound read back through float32 may round below by an ulp.
        if lowest < -maps.max_dent_depth * (1 + 1e-6):
            raise ArgumentError(
                f"heights must not go below -max_dent_depth ({-maps.max_dent_depth:g} m), got "
                f"{lowest:g} m; make the surface with a larger max_dent_depth"
            )
        assert self._gpu is not None
        self._forget_undo(maps)  # undo no longer reaches back past new heights
        self._start = np.array(data, dtype=np.float32)
        with preserved(self._gl.ctx):
            maps.height.write(np.ascontiguousarray(data).tobytes())
            maps.max_height = max(float(data.max()), 0.0)
            rebuild_all_normals(self._gl, self._gpu, maps)

    def _forget_undo(self, maps: SurfaceMaps) -> None:
        log = _undo_log(self._gl.ctx, make=False)
        if log is not None:
            log.forget(maps)

    def _body(self, name: str) -> CarveBody:
        maps = self._live(name)
        assert self._gpu is not None
        return CarveBody(self._gpu, maps, _pose(f"{name}.model", self._model))


def _read_npy(path: Path) -> NDArray:
    """A height array saved with numpy.save, or an error naming the file."""
    try:
        return np.load(path, allow_pickle=False)
    except OSError as exc:
        raise ArgumentError(f"heights: cannot read {path} ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ArgumentError(f"heights: {path} is not a .npy array ({exc})") from None


class Carver:
    """Carves dents: `press` moves a tool surface into a target surface along a contact.

    Undo: before each `press` or `press_many` call the texels it may write (both surfaces'
    heights and normals) are copied on the GPU, so `undo()` takes back the last call exactly,
    bit for bit, then the one before, up to 64 calls and 64 MiB of copies (8 bytes a texel; the
    oldest are dropped first; a call whose copies alone exceed 64 MiB is carved but not
    recorded, with one dentdemo.errors.UndoWarning, and the calls before it stay: undoing them
    restores their texels, its dents among them). The history is one per moderngl context,
    shared by its Carvers. It lives on the GPU only: it is not saved with `heights()` and is not
    restored by `set_heights`, which (like `repair` and `release`) drops that surface's part of
    it."""

    __slots__ = ("_ctx", "_carver", "_log")

    def __init__(self, ctx: moderngl.Context) -> None:
        if not isinstance(ctx, moderngl.Context):
            raise ArgumentError(f"ctx must be a moderngl.Context, got {type(ctx).__name__}")
        self._ctx = ctx
        _wrap(ctx).check_current("Carver()")
        self._log: SurfaceRecorder | None = None
        with preserved(ctx):
            options = CarverOptions(undo_log=_undo_log(ctx))
            self._carver: _Carver | None = _Carver(_wrap(ctx), options)

    @_in_context
    def press(
        self,
        target: DentableSurface,
        tool: DentableSurface,
        contact: Contact,
        depth: float,
        tool_depth: float = 0.0,
    ) -> bool:
        """Dent `target` where `tool` (posed at first touch) moves `depth` metres into it along
        `contact.direction`, and `tool` where it moves `tool_depth` the other way; normals are
        rebuilt around the dents. Every surface point inside the solid the tool sweeps moves
        inwards along its own normal until it leaves it: square-on into a flat surface the
        dent is `depth` deep, at an angle t from the normal `depth * cos(t)` (the direction may
        be a velocity). Only what the tool meets is dented: parts of the same mesh behind the
        tool neither take a dent nor hide the surface it presses. A press deepens a dent only
        (the same press twice changes nothing). Nothing is read back. False, with no GPU work,
        when the bodies cannot meet (a tool moving off or along the surface) or the depths are
        not positive."""
        return self._carve([(target, tool, contact, depth, tool_depth)], named=False)[0]

    @_in_context
    def press_many(self, presses: Sequence[Sequence[object]]) -> list[bool]:
        """Every press of a frame at once: `presses` holds (target, tool, contact, depth) or
        (target, tool, contact, depth, tool_depth) tuples, each as for `press`, all checked
        before any GPU work. They are carved as one batch: every press reads the heights from
        before the batch, each pass runs once for all of them (far cheaper than one press at a
        time), and where two presses dent the same texels the deeper wins. Presses whose dents
        do not overlap give exactly what pressing them one by one gives. A surface may be the
        target of one press and the tool of another. Returns, for each press, whether its
        bodies could meet."""
        return self._carve(presses, named=True)

    def _carve(self, presses: Sequence[Sequence[object]], named: bool) -> list[bool]:
        """press_many(); a bad argument's error starts with `presses[i]: ` when `named`."""
        if isinstance(presses, str | bytes) or not isinstance(presses, Sequence):
            raise ArgumentError(f"presses must be a list of presses, got {type(presses).__name__}")
        checked: list[tuple[DentableSurface, DentableSurface, Contact, float, float]] = []
        for index, press in enumerate(presses):
            if not isinstance(press, Sequence) or len(press) not in (4, 5):
                raise ArgumentError(
                    f"presses[{index}] must be (target, tool, contact, depth[, tool_depth]), "
                    f"got {press!r}"
                )
            target, tool, contact, depth, *rest = press
            try:
                depth_m, tool_m = self._arguments(target, tool, contact, depth, *rest)
            except ArgumentError as exc:
                if not named:  # press(): its own arguments
                    raise
                raise ArgumentError(f"presses[{index}]: {exc}") from None
            assert isinstance(target, DentableSurface) and isinstance(tool, DentableSurface)
            assert isinstance(contact, Contact)
            checked.append((target, tool, contact, depth_m, tool_m))
        carver = self._live()
        if self._log is not None:
            self._log.check(s for press in checked for s in press[:2])
            self._log.presses(checked)
        planned = carver.plan_many(
            [
                Press(
                    target._body("target"),
                    tool._body("tool"),
                    ContactFrame(contact.point, contact.direction),
                    depth_m,
                    tool_m,
                )
                for target, tool, contact, depth_m, tool_m in checked
            ]
        )
        carver.carve_hits(planned)
        return [bool(jobs) for jobs in planned]

    @_in_context
    def undo(self) -> bool:
        """Take back the last `press` or `press_many` call of this context (both surfaces of
        each press, bit for bit): True, or False with nothing done when no call is left to
        undo (none yet, all undone, or older than the 64 kept)."""
        log = self._live().options.undo_log
        undone = log is not None and log.undo()
        if undone and self._log is not None:
            self._log.event("undo")
        return undone

    def log_to(
        self,
        sink: Callable[[Record], None] | None,
        surfaces: Mapping[str, DentableSurface] | None = None,
    ) -> None:
        """From now on hand every press, undo and repair of this Carver to `sink` as hit-log
        records (dentdemo.hitlog: `to_bytes`, `to_lines`, `Encoder` for a stream), naming each
        surface by its key in `surfaces`; a press of a surface not named there is a ValueError.
        `dentdemo.replay(records, surfaces, carver)` carves them elsewhere. None stops it."""
        self._live()
        self._log = None if sink is None else SurfaceRecorder(sink, surfaces or {}, DentableSurface)

    @_in_context
    def prepare(self, *surfaces: DentableSurface) -> None:
        """Make now what the first presses of `surfaces` would make inside them: the vertex
        arrays and index streams of every pass that may draw each one, and the shader variants
        the driver compiles when a pass first draws under a new state (several at a surface's
        first presses, each a visible stall on llvmpipe). For a host's loading screen, not its
        frame loop; no texel changes, and the host's GL state is left as it was."""
        carver = self._live()
        ready: list[tuple[GpuMesh, SurfaceMaps]] = []  # every surface checked before any GL work
        for index, surface in enumerate(surfaces):
            if not isinstance(surface, DentableSurface):
                kind = type(surface).__name__
                raise ArgumentError(f"surfaces[{index}] must be a DentableSurface, got {kind}")
            maps = surface._live("prepare()")
            if surface._gl.ctx is not self._ctx:
                raise ArgumentError(
                    f"surfaces[{index}] was made in another moderngl context than this Carver"
                )
            assert surface._gpu is not None
            ready.append((surface._gpu, maps))
        for gpu_mesh, maps in ready:
            with preserved(self._ctx):
                carver.prepare(gpu_mesh)
            carver.warm(gpu_mesh, maps)

    @_in_context
    def repair(self, surface: DentableSurface) -> None:
        """Give `surface` back the maps it was made with: heights 0 (or those last given to
        `set_heights` / `set_bump_map`) and their normals, on the GPU. Its part of the undo
        history is dropped: a later `undo()` restores only the other surfaces of a press."""
        self._live()
        if not isinstance(surface, DentableSurface):
            raise ArgumentError(f"surface must be a DentableSurface, got {type(surface).__name__}")
        maps = surface._live("repair()")
        if surface._gl.ctx is not self._ctx:
            raise ArgumentError("surface was made in another moderngl context than this Carver")
        assert surface._gpu is not None
        surface._forget_undo(maps)
        restore_pristine(surface._gl, surface._gpu, maps, surface._start)
        if self._log is not None:
            self._log.event("repair", surface)

    def release(self) -> None:
        """Free the collision camera's buffers (again, or once the context is released:
        nothing on the GPU)."""
        if self._carver is not None and _alive(self._ctx):
            self._context().check_current("release()")
            self._carver.release()
        self._carver = None

    def _context(self) -> GLContext:
        return _wrap(self._ctx)

    def _live(self) -> _Carver:
        if self._carver is None:
            raise ArgumentError("this Carver was released; make a new one")
        return self._carver

    def _arguments(
        self,
        target: object,
        tool: object,
        contact: object,
        depth: object,
        tool_depth: object = 0.0,
    ) -> tuple[float, float]:
        """press()'s arguments checked: both depths as floats."""
        self._live()
        for name, surface in (("target", target), ("tool", tool)):
            if not isinstance(surface, DentableSurface):
                raise ArgumentError(
                    f"{name} must be a DentableSurface, got {type(surface).__name__}"
                )
            surface._live(name)
            if surface._gl.ctx is not self._ctx:
                raise ArgumentError(f"{name} was made in another moderngl context than this Carver")
        if target is tool:
            raise ArgumentError(
                "target and tool are the same DentableSurface: a surface cannot be pressed "
                "into itself"
            )
        if not isinstance(contact, Contact):
            raise ArgumentError(f"contact must be a dentdemo.Contact, got {type(contact).__name__}")
        metres = "a finite number of metres >= 0"
        return _real("depth", depth, metres), _real("tool_depth", tool_depth, metres)


def export_gltf(
    path: str | os.PathLike[str],
    surfaces: Sequence[DentableSurface],
    names: Sequence[str] | None = None,
    looks: Sequence[Appearance | str] | None = None,
) -> Path:
    """Write `surfaces`, each at its `model` pose, to a glTF 2.0 file: `.glb` (binary) or
    `.gltf` (JSON with the data embedded). Each surface is one node named by `names` (default
    surface_0, surface_1, ...) whose primitive carries the mesh with NORMAL, TANGENT
    (`Mesh.tangents`: glTF's bitangent cross(N, T) * w is the one the normal map is built
    with) and TEXCOORD_0 (the dent atlas; TEXCOORD_1 where the mesh's own base-colour image is
    sampled by other coordinates), and a metallic-roughness material: `looks` gives each
    surface an Appearance or a preset name of assets/materials.toml (default: grey, half
    rough), the mesh's own image is its baseColorTexture, the normal map read back from the GPU
    its normalTexture, and `extras.dentdemo_height` references the height map as a 16-bit PNG
    with `offset_m` and `metres_per_unit` (height_m = offset_m + metres_per_unit * value).
    Returns the path. The host's GL state is left as it was."""
    from dentdemo.gltf import GltfBody, check_path, dented_part, trs, write_gltf

    try:
        target = check_path("path", Path(path))
    except TypeError:
        raise ArgumentError(f"path must be a .glb or .gltf file name, got {path!r}") from None
    except DentdemoError as exc:
        raise ArgumentError(str(exc)) from None
    if isinstance(surfaces, str | bytes) or not isinstance(surfaces, Iterable):
        raise ArgumentError(f"surfaces must be one or more DentableSurface, got {surfaces!r}")
    surfaces = list(surfaces)
    if not surfaces or not all(isinstance(s, DentableSurface) for s in surfaces):
        raise ArgumentError(f"surfaces must be one or more DentableSurface, got {surfaces!r}")
    names = [f"surface_{i}" for i in range(len(surfaces))] if names is None else list(names)
    chosen = [Appearance()] * len(surfaces) if looks is None else list(looks)
    for argument, values in (("names", names), ("looks", chosen)):
        if len(values) != len(surfaces):
            raise ArgumentError(
                f"{argument} must have one entry per surface ({len(surfaces)}), got {len(values)}"
            )
    from dentdemo.model.materials import load_materials

    library = load_materials() if any(isinstance(look, str) for look in chosen) else None
    appearances = [_appearance(f"looks[{i}]", look, library) for i, look in enumerate(chosen)]
    every_maps = [surface._live("export_gltf()") for surface in surfaces]
    for index, surface in enumerate(surfaces):
        try:
            trs(surface.model)  # a glTF node's pose: no shear
        except DentdemoError as exc:
            raise ArgumentError(f"surfaces[{index}].model: {exc}") from None
    for surface in surfaces:
        surface._gl.check_current("export_gltf()")
    bodies = []
    for surface, name, look, maps in zip(surfaces, names, appearances, every_maps, strict=True):
        part = dented_part(surface._gl, surface.mesh, look, maps)
        bodies.append(GltfBody(str(name), surface.model, (part,)))
    return write_gltf(target, bodies)


def _appearance(name: str, look: object, library: MaterialLibrary | None) -> Appearance:
    """`look` (an Appearance, or the name of a preset of `library`) as an Appearance, or an
    error naming `name`."""
    if isinstance(look, Appearance):
        return _checked_look(name, look)
    if not isinstance(look, str) or library is None:
        raise ArgumentError(
            f"{name} must be an Appearance or a preset name, got {type(look).__name__}"
        )
    try:
        return library.get(look, name).appearance
    except ConfigError as exc:
        raise ArgumentError(str(exc)) from None


def _checked_look(name: str, look: Appearance) -> Appearance:
    """`look` when every field is in its range (the materials file's), else an error naming
    `name`, the field and its value."""
    colour = look.base_colour
    try:
        rgb = np.array(colour, dtype=np.float64)
    except (TypeError, ValueError):
        rgb = np.zeros(0)
    if rgb.shape != (3,) or not ((rgb >= 0) & (rgb <= 1)).all():
        raise ArgumentError(
            f"{name}.base_colour must be 3 numbers in [0, 1] (linear RGB), got {colour!r}"
        )
    for key in ("metalness", "roughness"):
        value, low, high = getattr(look, key), NUMBER_KEYS[key].low, NUMBER_KEYS[key].high
        real = isinstance(value, numbers.Real) and not isinstance(value, bool)
        if not (real and low is not None and high is not None and low <= value <= high):
            raise ArgumentError(
                f"{name}.{key} must be a number in [{low:g}, {high:g}], got {value!r}"
            )
    if look.surface not in SURFACES:
        raise ArgumentError(
            f"{name}.surface must be one of {', '.join(SURFACES)}, got {look.surface!r}"
        )
    return look


def replay(
    records: Iterable[Record] | bytes,
    surfaces: Mapping[str, DentableSurface],
    carver: Carver,
) -> int:
    """Carve hit-log records (a list of records, or a log's bytes in either form) onto
    `surfaces`, each named as the log names it, with `carver`: each batch is one `press_many`
    with the recorded poses (each surface's `model` is put back afterwards), an undo is
    `carver.undo()`, a repair `carver.repair`. The whole log is checked first: a bad record, a
    name `surfaces` lacks or a surface whose map side differs is a ValueError naming the record,
    and nothing is carved. Returns the presses carved. On the same driver the maps come out bit
    for bit as the sender's."""
    try:
        if isinstance(records, bytes | bytearray):
            checked = hitlog.parse(bytes(records), "records")
        else:
            checked = hitlog.check(list(records))
    except HitLogError as exc:
        raise ArgumentError(str(exc)) from None
    by_index: dict[int, DentableSurface] = {}
    for n, record in enumerate(checked, 1):
        if isinstance(record, Body):
            surface = surfaces.get(record.id)
            if not isinstance(surface, DentableSurface):
                raise ArgumentError(f"record {n}: no surface named '{record.id}' in surfaces")
            if record.spec.get("map_size") != surface.map_size:
                raise ArgumentError(
                    f"record {n}: '{record.id}' had {record.spec.get('map_size')}^2 maps, "
                    f"the surface has {surface.map_size}^2"
                )
            by_index[record.index] = surface
        elif isinstance(record, Event) and record.kind in ("reset", "depth_bound"):
            raise ArgumentError(f"record {n}: a '{record.kind}' has no DentableSurface meaning")
    kept = {id(s): (s, s.model.copy()) for s in by_index.values()}
    carved = 0
    batch: list[Hit] = []

    def flush() -> None:
        nonlocal carved
        if not batch:
            return
        for hit in batch:  # one pose a surface within a call, as when it was recorded
            by_index[hit.target].model = hitlog.pose_matrix(hit.target_pose)
            by_index[hit.tool].model = hitlog.pose_matrix(hit.tool_pose)
        carver.press_many(
            [
                (
                    by_index[h.target],
                    by_index[h.tool],
                    Contact(h.point, h.direction),
                    h.target_depth,
                    h.tool_depth,
                )
                for h in batch
            ]
        )
        carved += len(batch)
        batch.clear()

    try:
        for record in checked:
            if isinstance(record, Hit):
                if batch and batch[0].batch != record.batch:
                    flush()
                batch.append(record)
                continue
            flush()
            if isinstance(record, Event) and record.kind == "undo":
                carver.undo()
            elif isinstance(record, Event) and record.kind == "repair":
                carver.repair(by_index[record.body])
        flush()
    finally:
        for surface, model in kept.values():
            surface.model = model
    return carved
