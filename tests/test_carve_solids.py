"""Pass 1's footprint bound of built-in solids worked out as arrays over a batch's directions
(`carve/solids.py`), against the same bound worked out one direction at a time on Python floats
(`footprint.overlap`): the same bits for every pair of shapes, posed turned, scaled and
mirrored, pressed in any direction, with bumps and advances; and a batch's cameras the same
bits as each one's alone."""

from __future__ import annotations

import numpy as np
import pytest

from dentdemo.carve import camera, lanes, solids
from dentdemo.carve.camera import BodyPose, ContactFrame, DraftRequest, camera_drafts
from dentdemo.carve.footprint import Projected, overlap
from dentdemo.model.shapes import Box, Capsule, Cylinder, Plate, Sphere
from surface_helpers import press_mesh

_MESHES = [
    press_mesh(Sphere(0.05), 1),
    press_mesh(Capsule(0.03, 0.1), 1),
    press_mesh(Box((0.2, 0.1, 0.3)), 2),
    press_mesh(Plate(1.0), 2),
    press_mesh(Cylinder(0.05, 0.2), 1),
]


def _pose(rng: np.random.Generator) -> np.ndarray:
    """A turned (a fifth of them mirrored), scaled and moved pose (world from local)."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if rng.uniform() < 0.8:
        q *= np.sign(np.linalg.det(q))
    model = np.eye(4)
    model[:3, :3] = q * rng.uniform(0.5, 2.0)
    model[:3, 3] = rng.normal(scale=0.05, size=3)
    return model


def _requests(seed: int, count: int, pairs: list[tuple[int, int]] | None = None) -> list:
    """Presses of one built-in shape into another, near each other, posed at random."""
    rng = np.random.default_rng(seed)
    requests = []
    for k in range(count):
        if pairs is None:
            target, tool = _MESHES[rng.integers(5)], _MESHES[rng.integers(5)]
        else:
            target, tool = (_MESHES[i] for i in pairs[k % len(pairs)])
        direction = rng.normal(size=3)
        requests.append(
            DraftRequest(
                BodyPose(target, _pose(rng), max_height=float(rng.choice([0.0, 1e-3]))),
                BodyPose(tool, _pose(rng), max_height=float(rng.choice([0.0, 2e-3]))),
                (256, 256),
                ContactFrame(rng.normal(scale=0.03, size=3), direction / np.linalg.norm(direction)),
                advance=float(rng.uniform(0.0, 0.01)),
            )
        )
    return requests


@pytest.mark.parametrize("seed", range(3))
def test_the_bound_of_a_batchs_solids_is_each_directions_own(seed: int) -> None:
    """`solids.overlap_solids` over 300 directions (every pair of the five built-in shapes)
    gives each the bits `footprint.overlap` gives it alone on Python floats, and None (no
    overlap) for the same directions."""
    requests = _requests(seed, 300)
    frames = camera._frames(requests, lanes.ARRAY)
    axes, origin = frames.axes_array, frames.origin_array
    compared = 0
    groups: dict[tuple, list[int]] = {}
    for k, r in enumerate(requests):
        kinds = (solids.solid_kind(r.target.mesh), solids.solid_kind(r.tool.mesh))
        groups.setdefault(kinds, []).append(k)
    assert len(groups) == 9  # every pair of the three kinds (swept sphere, plate, box)
    for (target_kind, tool_kind), members in groups.items():
        chosen = [requests[k] for k in members]
        poses = [
            _poses([getattr(r, body).model for r in chosen], axes[members], origin[members])
            for body in ("target", "tool")
        ]
        found = solids.overlap_solids(
            solids.Solids([r.target.mesh.bound for r in chosen], poses[0], target_kind[-1]),
            solids.Solids([r.tool.mesh.bound for r in chosen], poses[1], tool_kind[-1]),
            *np.array([(r.target.max_height, r.tool.max_height, r.advance) for r in chosen]).T,
        )
        for i, (k, r) in enumerate(zip(members, chosen, strict=True)):
            target = Projected(r.target.mesh, r.target.model, origin[k], axes[k])
            tool = Projected(r.tool.mesh, r.tool.model, origin[k], axes[k])
            alone = overlap(target, tool, r.target.max_height, r.tool.max_height, r.advance)
            assert bool(found.meets[i]) == (alone is not None)
            if alone is None:
                continue
            compared += 1
            got = [float(x[i]) for x in (*found.rect, *found.slab)]
            want = [alone.rect.x0, alone.rect.x1, alone.rect.y0, alone.rect.y1, *alone.slab]
            assert np.array(got).tobytes() == np.array(want).tobytes()
            ranges = [float(x[i]) for x in (*found.target_s, *found.tool_s)]
            assert (
                np.array(ranges).tobytes()
                == np.array([*target.s_range(), *tool.s_range()]).tobytes()
            )
    assert compared > 200  # most of them meet


def _poses(models: list, axes: np.ndarray, origin: np.ndarray) -> solids.Poses:
    """Bodies posed in their cameras (`solids.Poses`), each worked out alone on floats."""
    one = [
        solids.pose_lanes(
            lanes.ONE, tuple(a.tolist()), tuple(o.tolist()), np.asarray(m)[:3].tolist()
        ).arrays(lanes.ONE)
        for m, a, o in zip(models, axes, origin, strict=True)
    ]
    return solids.Poses(*(np.concatenate(x) for x in zip(*one, strict=True)))


@pytest.mark.parametrize("seed", range(2))
def test_a_batchs_cameras_are_each_directions_own_with_array_bounds(seed: int) -> None:
    """A batch of 40 directions, plates and spheres each way and boxes into plates (the
    footprint bounds of each pair of kinds worked out as arrays), gives every camera the bits
    it gets alone (bounds on Python floats), whatever the batch's order."""
    requests = _requests(seed, 40, [(3, 0), (0, 3), (2, 3), (0, 0)])
    assert len(requests) // 4 >= solids.ARRAY_BOUNDS
    batch = camera_drafts(requests, 1023)
    backwards = camera_drafts(requests[::-1], 1023)[::-1]
    assert sum(d is not None for d in batch) > 20
    for request, draft, reversed_draft in zip(requests, batch, backwards, strict=True):
        (alone,) = camera_drafts([request], 1023)
        for other in (draft, reversed_draft):
            assert (other is None) == (alone is None)
            if alone is None or other is None:
                continue
            assert other.view == alone.view and other.texel_view == alone.texel_view
            assert other.texel_slab == alone.texel_slab and other.tool_slab == alone.tool_slab
            for key, value in alone.fields.items():
                assert np.asarray(other.fields[key]).tobytes() == np.asarray(value).tobytes()
