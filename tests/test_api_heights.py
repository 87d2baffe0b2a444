"""A host puts heights back (an array, or the .npy that heights() or --maps-dir saved) or starts
from a bump-map image, and the normals are rebuilt on the GPU: checked against heights the test
wrote and the analytic slope of a surface it chose."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

import dentdemo
from dentdemo.errors import ArgumentError

SIDE = 0.4  # plate side, m: texel (i, j) is at u = (j + 0.5) / N, v = (i + 0.5) / N
PLATE = dentdemo.shape_mesh(dentdemo.Plate(SIDE))
DOWN = dentdemo.Contact((0.0, 0.0, 0.0), (0.0, -1.0, 0.0))


def _normals(surface: dentdemo.DentableSurface, gl) -> np.ndarray:
    """The normal map read back, unit tangent-space vectors [v, u, 3]."""
    rgb = gl.read(surface.normal)[:, :, :3].astype(np.float64) / 255.0 * 2.0 - 1.0
    return rgb / np.linalg.norm(rgb, axis=2, keepdims=True)


def _waves(n: int, amplitude: float) -> tuple[np.ndarray, np.ndarray]:
    """Heights h = A (sin 2 pi 2u + cos 2 pi 3v) / 2 on an n^2 plate map, metres, and their
    tangent-space normals normalize(-dh/ds_u, -dh/ds_v, 1), s = metres along +u and +v."""
    c = (np.arange(n) + 0.5) / n
    v, u = np.meshgrid(c, c, indexing="ij")
    h = amplitude * (np.sin(2 * math.pi * 2 * u) + np.cos(2 * math.pi * 3 * v)) / 2
    dh_du = amplitude * 2 * math.pi * 2 * np.cos(2 * math.pi * 2 * u) / 2 / SIDE
    dh_dv = -amplitude * 2 * math.pi * 3 * np.sin(2 * math.pi * 3 * v) / 2 / SIDE
    n_ts = np.stack([-dh_du, -dh_dv, np.ones_like(h)], axis=2)
    return h.astype(np.float32), n_ts / np.linalg.norm(n_ts, axis=2, keepdims=True)


def _degrees(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip((a * b).sum(axis=2), -1.0, 1.0)))


def _press(gl, surface, depth=0.004):
    ball = dentdemo.DentableSurface(gl.ctx, dentdemo.shape_mesh(dentdemo.Sphere(0.05)), 64)
    ball.model[1, 3] = 0.05
    carver = dentdemo.Carver(gl.ctx)
    pressed = carver.press(surface, ball, DOWN, depth)
    carver.release()
    ball.release()
    return pressed


def test_set_heights_rebuilds_the_normals_to_the_analytic_slope(gl):
    n = 128
    heights, expected = _waves(n, 0.006)  # slopes up to 0.12 (7 degrees)
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, n, max_dent_depth=0.01)
    try:
        inner = (slice(2, -2), slice(2, -2))  # central differences need both neighbours
        flat = _degrees(_normals(plate, gl), expected)[inner]
        plate.set_heights(heights)
        np.testing.assert_array_equal(plate.heights(), heights)
        error = _degrees(_normals(plate, gl), expected)[inner]
        print(f"normal error (deg): mean {error.mean():.3f} p95 {np.percentile(error, 95):.3f}")
        assert flat.mean() > 3.0  # the oracle tells a flat map from the waves
        assert error.mean() < 0.4 and np.percentile(error, 95) < 0.8 and error.max() < 1.2
    finally:
        plate.release()


def test_saved_heights_come_back_exactly_and_the_carve_continues(gl, tmp_path):
    """heights() saved with numpy.save (what --maps-dir writes), put into a fresh surface from
    the file: the same heights bit for bit, the same normals, and the same press again
    changes nothing while a deeper one deepens."""
    first = dentdemo.DentableSurface(gl.ctx, PLATE, 256)
    second = dentdemo.DentableSurface(gl.ctx, PLATE, 256)
    try:
        assert _press(gl, first, 0.004)
        saved = tmp_path / "plate_height.npy"
        np.save(saved, first.heights())
        second.set_heights(saved)
        np.testing.assert_array_equal(second.heights(), first.heights())
        # The carve rebuilt the dent's normals, set_heights all of them: the same pass 5.
        np.testing.assert_array_equal(gl.read(second.normal), gl.read(first.normal))
        before = second.heights()
        assert float(-before.min()) == pytest.approx(0.004, rel=0.02)
        _press(gl, second, 0.004)
        np.testing.assert_array_equal(second.heights(), before)
        _press(gl, second, 0.006)
        assert float(-second.heights().min()) == pytest.approx(0.006, rel=0.02)
    finally:
        first.release()
        second.release()


def _png(path, pixels: np.ndarray) -> str:
    Image.fromarray(pixels).save(path)
    return str(path)


@pytest.mark.parametrize("bits", [8, 16])
def test_a_bump_map_image_becomes_the_start_heights(gl, tmp_path, bits):
    """A greyscale ramp: white is `white_height` metres, black 0, the image's top row at v = 1
    (texture row n - 1); the normals tilt away from the rising side."""
    n, white = 64, 0.002
    top = 2**bits - 1
    ramp = np.round(np.linspace(0, top, n)).astype(np.uint16 if bits == 16 else np.uint8)
    pixels = np.tile(ramp, (n, 1))  # brighter to the right: h rises along +u
    pixels[:8] = 0  # the image's top 8 rows black: texture rows n - 8 .. n - 1
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, n)
    try:
        plate.set_bump_map(_png(tmp_path / "bump.png", pixels), white)
        expected = (pixels[::-1].astype(np.float64) / top * white).astype(np.float32)
        np.testing.assert_allclose(plate.heights(), expected, rtol=1e-6, atol=1e-9)
        normals = _normals(plate, gl)
        slope = white / SIDE  # metres per metre along u, over the ramp
        tilt = -slope / math.sqrt(1 + slope**2)
        np.testing.assert_allclose(normals[4 : n - 12, 4:-4, 0], tilt, atol=0.01)
        assert np.abs(normals[n - 6 :, 4:-4, :2]).max() < 0.01  # the black band is flat
    finally:
        plate.release()


def _bad_heights(tmp_path) -> list[tuple[object, tuple[str, ...]]]:
    (tmp_path / "text.npy").write_text("not an array")
    np.save(tmp_path / "objects.npy", np.array([None, 1], dtype=object), allow_pickle=True)
    np.save(tmp_path / "small.npy", np.zeros((8, 8), np.float32))
    return [
        (np.zeros((32, 64), np.float32), ("heights", "(64, 64)", "shape (32, 64)")),
        (np.zeros((64, 64), np.int32), ("heights", "float", "int32")),
        (np.full((64, 64), np.nan, np.float32), ("heights", "finite", "4096 NaN")),
        (np.full((64, 64), -0.02, np.float32), ("heights", "-max_dent_depth", "-0.01", "-0.02")),
        (tmp_path / "absent.npy", ("heights", "absent.npy", "No such file")),
        (tmp_path / "text.npy", ("heights", "text.npy", "not a .npy array")),
        (tmp_path / "objects.npy", ("heights", "objects.npy")),
        (str(tmp_path / "small.npy"), ("heights", "(64, 64)", "shape (8, 8)")),
    ]


def test_bad_heights_are_named_and_change_nothing(gl, tmp_path):
    plate = dentdemo.DentableSurface(gl.ctx, PLATE, 64, max_dent_depth=0.01)
    try:
        assert _press(gl, plate, 0.004)
        before = plate.heights()
        for value, fragments in _bad_heights(tmp_path):
            with pytest.raises(ArgumentError) as info:
                plate.set_heights(value)
            for fragment in fragments:
                assert fragment in str(info.value), (fragment, str(info.value))
        for path, white, fragment in (
            (tmp_path / "absent.png", 0.001, "absent.png"),
            (tmp_path / "text.npy", 0.001, "cannot read the height image"),
            (tmp_path / "bump.png", -0.001, "white_height must be"),
            (tmp_path / "bump.png", math.nan, "got nan"),
        ):
            with pytest.raises(ValueError, match=fragment):
                plate.set_bump_map(path, white)
        np.testing.assert_array_equal(plate.heights(), before)
    finally:
        plate.release()
