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
