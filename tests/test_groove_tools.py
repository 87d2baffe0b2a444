"""The swept tools a sandbox's grooves are pressed with (app/wear.GrooveTools): what they hold
on the GPU stays bounded however many sizes of capsule the grooves ask for, and a capsule that
shares its maps with others dents exactly as one with maps of its own."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dentdemo.app import wear
from dentdemo.app.press import make_setup
from dentdemo.app.wear import CAPSULES_KEPT, LENGTH_STEP, GrooveTool, GrooveTools
from dentdemo.carve.camera import ContactFrame
from dentdemo.carve.carver import CarveBody, Carver, Press
from dentdemo.carve.surface import create_maps, map_size_for
from dentdemo.gpu.mesh import GpuMesh
from dentdemo.mesh.shapes import Tessellation, shape_mesh
from dentdemo.model.shapes import Capsule, Plate, Sphere


class _Ledger:
    """The GPU meshes and maps wear.py makes, and which of them it has released."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.meshes: list[GpuMesh] = []
        self.maps: list[object] = []
        self.released: set[int] = set()
        ledger = self

        class CountedMesh(GpuMesh):
            def __init__(self, *args, **kwargs) -> None:
                super().__init__(*args, **kwargs)
                ledger.meshes.append(self)

            def release(self) -> None:
                ledger.released.add(id(self))
                super().release()

        def counted_maps(*args, **kwargs):
            maps = create_maps(*args, **kwargs)
            ledger.maps.append(maps)
            release = maps.release

            def counted_release() -> None:
                ledger.released.add(id(maps))
                release()

            maps.release = counted_release  # type: ignore[method-assign]
            return maps

        monkeypatch.setattr(wear, "GpuMesh", CountedMesh)
        monkeypatch.setattr(wear, "create_maps", counted_maps)

    def live(self, made: list) -> list:
        return [thing for thing in made if id(thing) not in self.released]


def _worn(texel: float) -> SimpleNamespace:
    """What `GrooveTools.body` reads of the worn body's maps: their texel size."""
    return SimpleNamespace(texel_metres=(texel, texel))


def _capsule(k: int) -> GrooveTool:
    """The k-th of many capsules: radii from 2 mm, lengths in whole LENGTH_STEPs."""
    return GrooveTool(radius=0.002 + 1e-4 * (k % 37), length=LENGTH_STEP * (1 + k % 11))


def test_capsules_of_many_sizes_hold_a_bounded_set_of_meshes_and_maps(gl, monkeypatch):
    """Grooves of 150 capsule sizes (balls of many radii, paths of many lengths) on bodies of
    two texel sizes, ten a batch: at most CAPSULES_KEPT capsule meshes stay on the GPU, and one
    set of maps per map side the capsules use (before: a mesh and a set of maps, up to 9 MiB,
    for every size and side, for as long as the sandbox ran)."""
    ledger = _Ledger(monkeypatch)
    tools = GrooveTools(gl)
    sides = set()
    try:
        for k in range(150):
            if k % 10 == 0:
                tools.next_batch()
            for texel in (1e-3, 2.5e-4):
                body = tools.body(_capsule(k), _worn(texel), np.eye(4))
                sides.add(body.maps.size)
            assert len(ledger.live(ledger.meshes)) <= CAPSULES_KEPT
        assert len(ledger.live(ledger.maps)) == len(sides)
        assert len(ledger.meshes) >= 150  # the sizes really were many
    finally:
        tools.release()
    assert not ledger.live(ledger.meshes) and not ledger.live(ledger.maps)


def test_a_batch_keeps_every_capsule_it_was_given(gl, monkeypatch):
    """More capsule sizes in one batch than CAPSULES_KEPT: none is released while the batch's
    presses may still be carved; the next batch's first new capsule trims the rest."""
    ledger = _Ledger(monkeypatch)
    tools = GrooveTools(gl)
    try:
        tools.next_batch()
        given = [tools.body(_capsule(k), _worn(1e-3), np.eye(4)) for k in range(CAPSULES_KEPT + 8)]
        assert all(id(body.gpu_mesh) not in ledger.released for body in given)
        tools.next_batch()
        tools.body(GrooveTool(radius=0.05, length=LENGTH_STEP), _worn(1e-3), np.eye(4))
        assert len(ledger.live(ledger.meshes)) == CAPSULES_KEPT
        assert sum(id(body.gpu_mesh) in ledger.released for body in given) == 9
    finally:
        tools.release()


def _groove_heights(gl, tool_body) -> np.ndarray:
    """A plate's heights after one press of `tool_body`'s capsule (lying along x, 0.1 mm into
    the plate's top, pressed straight down at its middle)."""
    setup = make_setup(gl, Plate(0.3, 0.02), Sphere(0.01), 512, 64)
    try:
        radius = tool_body.gpu_mesh.mesh.bound.radius
        model = np.eye(4)
        model[:3, :3] = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]  # axis z -> x
        model[:3, 3] = setup.contact.point + np.array([0.0, radius, 0.0])
        tool = CarveBody(tool_body.gpu_mesh, tool_body.maps, model)
        carver = Carver(gl)
        contact = ContactFrame(np.asarray(setup.contact.point), np.array([0.0, -1.0, 0.0]))
        carver.carve_many([Press(setup.target, tool, contact, 1e-4)])
        carver.release()
        return gl.read(setup.target.maps.height)
    finally:
        for body in (setup.target, setup.tool):
            body.maps.release()
            body.gpu_mesh.release()


def test_a_capsule_sharing_maps_dents_as_one_with_its_own(gl):
    """A capsule whose maps are a view of another capsule's (the first of its map side) carves
    the same bits as the same capsule with maps made for it alone, and does dent the plate."""
    tools = GrooveTools(gl)
    texel = 0.3 / 512
    try:
        tools.body(GrooveTool(radius=0.004, length=2 * LENGTH_STEP), _worn(texel), np.eye(4))
        tool = GrooveTool(radius=0.004, length=3 * LENGTH_STEP)
        shared = tools.body(tool, _worn(texel), np.eye(4))
        mesh = shape_mesh(Capsule(tool.radius, tool.length), Tessellation())
        own_gpu = GpuMesh(gl, mesh)
        side = shared.maps.size[0]
        assert side == wear._power_of_two(map_size_for(mesh, 1.0 / texel, cap=wear.TOOL_MAP_MAX))
        own_maps = create_maps(gl, own_gpu, side, 0.0)
        try:
            assert shared.maps.texel_metres == own_maps.texel_metres
            assert shared.maps.height is not own_maps.height
            with_shared = _groove_heights(gl, shared)
            with_own = _groove_heights(gl, CarveBody(own_gpu, own_maps, np.eye(4)))
        finally:
            own_maps.release()
            own_gpu.release()
    finally:
        tools.release()
    assert with_shared.min() < -0.5e-4  # dented (0.1 mm at the texel centres on its axis)
    assert np.array_equal(with_shared, with_own)
