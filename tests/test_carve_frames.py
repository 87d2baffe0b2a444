"""Pass 1's camera frames, worked out for all the directions of a batch together
(`camera._frames` over array lanes, one expression per step) or one by one (over float lanes):
each one as its definition gives it, and the same bits alone as in any batch, either way."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dentdemo.carve.camera import BodyPose, ContactFrame, DraftRequest, _frames
from dentdemo.carve.constants import MIN_COS
from dentdemo.carve.lanes import ARRAY, ONE
from dentdemo.model.shapes import Box, Capsule, Plate, Sphere
from surface_helpers import press_mesh


def _pose(rng: np.random.Generator) -> np.ndarray:
    """A turned, scaled and moved pose (world from local)."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))  # a rotation
    model = np.eye(4)
    model[:3, :3] = q * rng.uniform(0.5, 2.0)
    model[:3, 3] = rng.normal(scale=0.3, size=3)
    return model


def _requests(seed: int) -> list[DraftRequest]:
    """Presses on a sphere, a capsule, a box and a plate, posed at random, each at a point inside
    one of its triangles (not on an edge, where the triangle picked would be a matter of
    rounding), against the normal there tilted at random; maps of 64 to 1024 texels a side, tools
    whose texels are finer or up to 20 times coarser."""
    rng = np.random.default_rng(seed)
    meshes = [
        press_mesh(Sphere(0.05), 1),
        press_mesh(Capsule(0.03, 0.1), 1),
        press_mesh(Box((0.2, 0.1, 0.3)), 2),
        press_mesh(Plate(1.0), 2),
    ]
    tool = press_mesh(Sphere(0.02), 1)
    requests = []
    for k in range(16):
        mesh = meshes[k % len(meshes)]
        model = _pose(rng)
        corners = mesh.positions[mesh.indices[int(rng.integers(len(mesh.indices)))]]
        weights = rng.dirichlet([4.0, 4.0, 4.0])
        point = model[:3, :3] @ (weights @ corners.astype(np.float64)) + model[:3, 3]
        normal = model[:3, :3] @ np.cross(corners[1] - corners[0], corners[2] - corners[0])
        direction = -normal / np.linalg.norm(normal) + rng.normal(scale=0.3, size=3)
        size = int(rng.choice([64, 256, 1024]))
        tool_texel = float(rng.uniform(0.0, 20.0)) / size
        requests.append(
            DraftRequest(
                BodyPose(mesh, model),
                BodyPose(tool, _pose(rng), texel_metres=tool_texel),
                (size, size),
                ContactFrame(point, direction * rng.uniform(0.5, 3.0)),
            )
        )
    return requests


def _edge_on() -> DraftRequest:
    """A plate pressed along its own +u direction: dP/du lies along the view, so `right`
    falls back to a fixed world axis across the view."""
    mesh = press_mesh(Plate(1.0), 2)
    dpdu = mesh.triangle_derivatives()[0][0]
    return DraftRequest(
        BodyPose(mesh, np.eye(4)),
        BodyPose(press_mesh(Sphere(0.02), 1), np.eye(4)),
        (256, 256),
        ContactFrame(np.array([0.1, 0.0, 0.2]), dpdu * 3.0),
    )


def _expected(request: DraftRequest):
    """The frame from its definition, in float64 numpy one direction at a time: forward along
    the press; right along the target's world dP/du (of the triangle `Mesh.frame_near` picks)
    less its part along forward, or world x (z where forward is nearly x) where dP/du is along
    it; up = right x forward; the pitch the texel's sides as seen across the view (at least
    MIN_COS of them), times the whole number of them in a tool texel (at least one); the
    origin the contact moved in uv to the centre of its texel."""
    model = np.asarray(request.target.model)
    linear = model[:3, :3]
    forward = request.contact.direction / np.linalg.norm(request.contact.direction)
    local = np.linalg.solve(linear, request.contact.point - model[:3, 3])
    surf = request.target.mesh.frame_near(local)
    dpdu, dpdv = linear @ surf.dpdu, linear @ surf.dpdv
    right = dpdu - (dpdu @ forward) * forward
    fell_back = bool(np.linalg.norm(right) < 1e-9 * np.linalg.norm(dpdu))
    if fell_back:
        fixed = np.array([1.0, 0.0, 0.0] if abs(forward[0]) < 0.9 else [0.0, 0.0, 1.0])
        right = fixed - (fixed @ forward) * forward
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    size = np.array(request.map_size, dtype=np.float64)
    texel = np.array([np.linalg.norm(dpdu), np.linalg.norm(dpdv)]) / size
    pitch = np.maximum(np.abs([dpdu @ right, dpdv @ up]) / size, MIN_COS * texel)
    pitch *= np.maximum(np.floor(request.tool.texel_metres / pitch), 1.0)
    shift = (np.floor(surf.uv * size) + 0.5) / size - surf.uv
    origin = request.contact.point + dpdu * shift[0] + dpdv * shift[1]
    return np.array([right, up, forward]), origin, texel, pitch, fell_back


@pytest.mark.parametrize("seed", range(3))
def test_a_batchs_camera_frames_are_each_directions_own(seed: int) -> None:
    """The frames of a batch (shapes turned and scaled, tilted presses, one edge-on plate whose
    dP/du lies along the view) are their definitions' (to 1e-12 of their size), and each one's
    bits are those it gets alone, as an array lane or a float, whatever else is in the batch
    and in whatever order."""
    requests = _requests(seed)
    requests.insert(5, _edge_on())
    frames = _each(_frames(requests, ARRAY))
    for request, frame in zip(requests, frames, strict=True):
        axes, origin, texel, pitch, _ = _expected(request)
        assert np.allclose(frame[0], axes, rtol=0.0, atol=1e-12)
        scale = math.sqrt(abs(np.linalg.det(np.asarray(request.target.model)[:3, :3])))
        assert np.allclose(frame[1], origin, rtol=0.0, atol=1e-12 * scale)
        assert np.allclose(frame[2], texel, rtol=1e-12, atol=0.0)
        assert np.allclose(frame[3], pitch, rtol=1e-12, atol=0.0)
    assert _expected(requests[5])[4]  # the edge-on plate's right is the fixed axis's
    for reordered in (requests[::-1], requests[3:9]):
        found = _each(_frames(reordered, ARRAY))
        again = {id(r): f for r, f in zip(reordered, found, strict=True)}
        for request, frame in zip(requests, frames, strict=True):
            if id(request) in again:
                _assert_same_bits(frame, again[id(request)])
    for request, frame in zip(requests, frames, strict=True):
        for mode in (ONE, ARRAY):
            (alone,) = _each(_frames([request], mode))
            _assert_same_bits(frame, alone)


def _each(frames) -> list[tuple[np.ndarray, ...]]:
    """Each direction's (axes, origin, texel sides, pitches) of a batch's frames."""
    texel = np.array(frames.texel, dtype=np.float64).reshape(2, -1).T
    pitch = np.array(frames.pitch, dtype=np.float64).reshape(2, -1).T
    return list(zip(frames.axes, frames.origin, texel, pitch, strict=True))


def _assert_same_bits(a, b) -> None:
    for x, y in zip(a, b, strict=True):
        assert x.tobytes() == y.tobytes()
