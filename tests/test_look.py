"""The dents are the first thing a person sees: a 1 mm dent (a 5 cm steel ball in an aluminium
plate) seen from 0.3 m and 40 degrees above the plate changes at least half of the pixels inside
its projected footprint by 10 sRGB levels or more, at the low and the high preset."""

from __future__ import annotations

import numpy as np
import pytest

from closeup_helpers import camera, footprint_mask, visible_fraction
from dentdemo.render.quality import PRESETS


def test_the_footprint_mask_is_the_projected_disc():
    mask = footprint_mask(camera())
    # A 9.95 mm disc at 0.3 m with a 35 degree field of view over 480 rows: about 30 pixels
    # across vertically foreshortened by sin(40 deg); its area in pixels, by hand: pi * a * b.
    focal = 240 / np.tan(np.radians(17.5))
    a = 0.00995 / 0.3 * focal
    area = np.pi * a * a * np.sin(np.radians(40))
    assert mask.sum() == pytest.approx(area, rel=0.1)


@pytest.mark.parametrize("quality", ["low", "high"])
@pytest.mark.slow
def test_a_one_millimetre_dent_is_visible_in_a_close_up(gl, quality):
    fraction, plain, dent = visible_fraction(gl, quality=PRESETS[quality])
    assert fraction >= 0.5, f"{fraction:.2%} of the footprint changed by 10 levels or more"
    # ...and the change is the dent, not noise: outside a margin around it nothing changes.
    outside = ~np.pad(footprint_mask(camera()), 0)
    grown = outside.copy()
    for axis in (0, 1):
        for shift in (-12, 12):
            grown &= np.roll(outside, shift, axis=axis)
    assert (np.abs(dent - plain).max(axis=2)[grown] >= 10).mean() < 0.001


def test_height_view_reads_in_millimetres_with_its_legend(gl):
    """The height view colours depth on a fixed millimetre scale, the same ramp its legend
    draws: the centre of a 1 mm dent, with a 5 mm full scale, is the ramp at 0.2."""
    from closeup_helpers import DEPTH, SIZE, render_closeup
    from dentdemo.render.frame import RenderOptions
    from dentdemo.render.legend import SIZE as LEGEND
    from dentdemo.render.legend import ramp

    options = RenderOptions(view=1, legend_depth=0.005)
    image = render_closeup(gl, True, options=options, quality=PRESETS["high"]).astype(int)
    x, y = camera().project(np.zeros(3), SIZE[0] / SIZE[1], SIZE)[0]
    expected = np.round(ramp(np.array(DEPTH / 0.005)) * 255)
    np.testing.assert_allclose(image[int(y), int(x)], expected, atol=3)
    # Untouched plate: the ramp's first stop; the legend sits in the bottom-left corner.
    np.testing.assert_allclose(image[40, 320], np.round(ramp(np.array(0.0)) * 255), atol=3)
    corner = image[SIZE[1] - 8 - LEGEND[1] + 2 : SIZE[1] - 10, 10 : 8 + LEGEND[0] - 2]
    assert corner.std() > 20  # the ramp and its labels, not the plate
