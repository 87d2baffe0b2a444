"""Archard's wear law and the grooves it cuts: the volume a sliding contact wears, and the depth of
the groove a tool of known cross-section cuts to remove it. Pure arithmetic, SI units (metres,
newtons, pascals), no GL."""

from __future__ import annotations

import math
from collections.abc import Callable

#: Bisection steps for a groove's depth: the bracket [0, R] halves each step, so 60 steps put
#: the depth within R * 2^-60 (below float64's resolution of it) of the root.
DEPTH_STEPS = 60


def archard_volume(
    wear_coefficient: float, load_n: float, slide_m: float, hardness_pa: float
) -> float:
    """V = K F s / H, m^3: the volume worn from a body of hardness H (Pa) and dimensionless wear
    coefficient K pressed with normal force F (N) while sliding s (m). Rolling without slip
    slides nothing (s = 0) and wears nothing."""
    if hardness_pa <= 0 or not math.isfinite(hardness_pa):
        raise ValueError(f"hardness must be a positive number of pascals, got {hardness_pa}")
    return max(wear_coefficient, 0.0) * max(load_n, 0.0) * max(slide_m, 0.0) / hardness_pa


def segment_area(radius: float, depth: float) -> float:
    """Cross-section of the groove a sphere (or a capsule's cylinder) pressed `depth` into a flat
    surface leaves, m^2: up to d = R the circular segment R^2 acos((R - d)/R) - (R - d)
    sqrt(2 R d - d^2); deeper, the tool's widest circle has passed the surface and the groove
    (a height map holds no undercut) is a half disc over a 2R-wide slot d - R deep."""
    r = radius
    d = max(depth, 0.0)
    if d > r:
        return math.pi * r * r / 2.0 + 2.0 * r * (d - r)
    return r * r * math.acos((r - d) / r) - (r - d) * math.sqrt(max(2.0 * r * d - d * d, 0.0))


def cap_volume(radius: float, depth: float) -> float:
    """Volume of the print a sphere pressed `depth` leaves, m^3: its cap pi d^2 (3R - d) / 3, and
    past d = R a hemisphere over a cylinder d - R deep (a groove's two half prints, at its start
    and end, make one)."""
    r = radius
    d = max(depth, 0.0)
    if d > r:
        return 2.0 * math.pi * r**3 / 3.0 + math.pi * r * r * (d - r)
    return math.pi * d * d * (3.0 * r - d) / 3.0


def segment_half_width(radius: float, depth: float) -> float:
    """Half the width of a sphere's groove `depth` deep at the surface, m: sqrt(2 R d - d^2), and
    R past d = R."""
    d = min(max(depth, 0.0), radius)
    return math.sqrt(max(2.0 * radius * d - d * d, 0.0))


def sphere_groove_depth(radius: float, area: float) -> float:
    """The depth d whose groove cross-section (`segment_area`) is `area`, m: past a half disc in
    closed form, else by bisection on [0, R] (the segment grows monotonically with d)."""
    if area <= 0.0:
        return 0.0
    half_disc = math.pi * radius * radius / 2.0
    if area >= half_disc:
        return radius + (area - half_disc) / (2.0 * radius)
    return _bisect(lambda d: segment_area(radius, d), area, radius)


def box_groove_depth(width: float, area: float) -> float:
    """The depth of a flat-bottomed groove `width` wide whose cross-section is `area`, m."""
    return max(area, 0.0) / width


def sphere_groove_profile(radius: float, depth: float, offset: float) -> float:
    """How deep a sphere's groove is `offset` metres across from its axis, m (>= 0): the circle
    of `radius` whose lowest point is `depth` below the surface."""
    reach = radius * radius - offset * offset
    if reach <= 0.0:
        return 0.0
    return max(depth - (radius - math.sqrt(reach)), 0.0)


def section_area(section: list[tuple[float, float]], depth: float) -> float:
    """Area of a convex cross-section (its corners counter-clockwise, (across, height) metres,
    height measured from the tool's lowest point up) below `depth`, m^2: the groove the tool cut
    `depth` deep leaves across its path (Sutherland-Hodgman against height <= depth, then the
    shoelace formula)."""
    clipped: list[tuple[float, float]] = []
    for i, (x0, y0) in enumerate(section):
        x1, y1 = section[(i + 1) % len(section)]
        inside0, inside1 = y0 <= depth, y1 <= depth
        if inside0:
            clipped.append((x0, y0))
        if inside0 != inside1:
            t = (depth - y0) / (y1 - y0)
            clipped.append((x0 + t * (x1 - x0), depth))
    area = 0.0
    for i, (x0, y0) in enumerate(clipped):
        x1, y1 = clipped[(i + 1) % len(clipped)]
        area += x0 * y1 - x1 * y0
    return abs(area) / 2.0


def section_depth(section: list[tuple[float, float]], area: float) -> float:
    """The depth at which `section_area` is `area`, m, by bisection over the section's height
    (deeper than the whole section: its full width on down)."""
    if area <= 0.0 or len(section) < 3:
        return 0.0
    top = max(y for _, y in section)
    whole = section_area(section, top)
    if area >= whole:
        width = max(x for x, _ in section) - min(x for x, _ in section)
        return top + (area - whole) / max(width, 1e-30)
    return _bisect(lambda d: section_area(section, d), area, top)


def _bisect(area_at: Callable[[float], float], area: float, deepest: float) -> float:
    """The depth in [0, `deepest`] where the increasing `area_at` reaches `area`, m."""
    lo, hi = 0.0, deepest
    for _ in range(DEPTH_STEPS):
        mid = 0.5 * (lo + hi)
        if area_at(mid) < area:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def lens_area(target_radius: float, radius: float, depth: float) -> float:
    """Cross-section of the groove a sphere of `radius` dragged along a great circle of a ball of
    `target_radius` cuts `depth` deep, m^2: the lens where the tool's circle (its centre
    c = R + r - d from the ball's) overlaps the ball's circle, in the plane through the ball's
    centre across the path. It is two circular segments on either side of their common chord,
    the tool's d (2R - d) / (2c) high and the ball's d (2r - d) / (2c), each in a form that
    keeps its digits when d is a millionth of R (acos near 1 would lose them)."""
    big, r = target_radius, radius
    d = min(max(depth, 0.0), 2.0 * min(big, r))
    if d <= 0.0:
        return 0.0
    c = big + r - d
    return _segment(r, d * (2.0 * big - d) / (2.0 * c)) + _segment(
        big, d * (2.0 * r - d) / (2.0 * c)
    )


def _segment(radius: float, height: float) -> float:
    """A circular segment `height` high cut from a circle of `radius`, m^2: R^2 theta - (R - h)
    sqrt(h (2R - h)) with its half-angle theta = 2 asin(sqrt(h / 2R))."""
    h = min(max(height, 0.0), 2.0 * radius)
    theta = 2.0 * math.asin(math.sqrt(h / (2.0 * radius)))
    return radius * radius * theta - (radius - h) * math.sqrt(h * (2.0 * radius - h))


def ball_lens_volume(target_radius: float, radius: float, depth: float) -> float:
    """Volume of the print a sphere of `radius` pressed `depth` into a ball of `target_radius`
    leaves, m^3: the two balls' overlap, pi (R + r - c)^2 (c^2 + 2 c r - 3 r^2 + 2 c R + 6 r R
    - 3 R^2) / (12 c) with c = R + r - d between their centres."""
    big, r = target_radius, radius
    d = min(max(depth, 0.0), 2.0 * min(big, r))
    c = big + r - d
    return (
        math.pi
        * d
        * d
        * (c * c + 2.0 * c * r - 3.0 * r * r + 2.0 * c * big + 6.0 * r * big - 3.0 * big * big)
        / (12.0 * c)
    )


def lens_groove_depth(target_radius: float, radius: float, area: float) -> float:
    """The depth whose `lens_area` is `area`, m, by bisection on [0, min(R, r)] (the lens grows
    monotonically with d); a groove past that is refused by the caller's thickness bound."""
    if area <= 0.0:
        return 0.0
    return _bisect(lambda d: lens_area(target_radius, radius, d), area, min(target_radius, radius))


def simplify_ring(ring: list[tuple[float, float]], keep: int) -> list[tuple[float, float]]:
    """A convex polygon (counter-clockwise) cut down to `keep` corners: the corner whose
    triangle with its two neighbours is smallest is dropped, again and again (Visvalingam); what
    is left is convex and inside the polygon, and lost only the thinnest slivers of it."""
    out = list(ring)
    while len(out) > keep:
        n = len(out)
        areas = []
        for i in range(n):
            (x0, y0), (x1, y1), (x2, y2) = out[i - 1], out[i], out[(i + 1) % n]
            areas.append(abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)))
        del out[areas.index(min(areas))]
    return out


def strip_area(radius: float, width: float, depth: float) -> float:
    """Cross-section of the groove a flat face `width` wide (square across the path) cuts
    `depth` deep into a ball of `radius` along a great circle, m^2: the ball's circular segment
    of that height, clipped to the face's width: over |x| <= a = min(w/2, sqrt(2 R d - d^2)),
    the integral of sqrt(R^2 - x^2) - (R - d), a sqrt(R^2 - a^2) + R^2 asin(a/R) - 2 a (R - d)."""
    r = radius
    d = min(max(depth, 0.0), r)
    a = min(width / 2.0, math.sqrt(max(2.0 * r * d - d * d, 0.0)))
    return a * math.sqrt(max(r * r - a * a, 0.0)) + r * r * math.asin(a / r) - 2.0 * a * (r - d)


def strip_groove_depth(radius: float, width: float, area: float) -> float:
    """The depth whose `strip_area` is `area`, m, by bisection on [0, R]."""
    if area <= 0.0:
        return 0.0
    return _bisect(lambda d: strip_area(radius, width, d), area, radius)


def section_area_beyond(section: list[tuple[float, float]], depth: float) -> float:
    """`section_area`, and past the section's top its full width on down (a tool pressed deeper
    than its own height sweeps walls), m^2."""
    top = max(y for _, y in section)
    if depth <= top:
        return section_area(section, depth)
    width = max(x for x, _ in section) - min(x for x, _ in section)
    return section_area(section, top) + (depth - top) * width


#: Doublings of the bracket for a coated groove's depth, from 1 nm: past 2^80 nm nothing is left.
BRACKET_DOUBLINGS = 80


def coated_depth(
    area_at: Callable[[float], float], area: float, coat: float, ratio: float
) -> float:
    """The depth of a groove through a coat `coat` metres thick whose material wears `ratio`
    times more than the coat for the same work ((K/H) / (K_coat/H_coat)), m. `area` is the
    cross-section the material alone would lose for the groove's work (Archard with its own K
    and H: the sandbox's and the scratch's volume over the path); the groove's cross-section
    below depth d, `area_at(d)`, splits into the coat's band, A(d) - A(d - t), and the
    material's below it, A(d - t); the work removes the coat at 1/ratio of the rate, so d solves
    ratio (A(d) - A(d - t)) + A(d - t) = area (bisection: the left side grows with d). Without a
    coat (or ratio 1) the material's own depth; a coat that never wears (ratio inf), none."""
    if area <= 0.0 or math.isinf(ratio):
        return 0.0

    def equivalent(d: float) -> float:
        below = area_at(max(d - coat, 0.0))
        return ratio * (area_at(d) - below) + below

    hi = 1e-9
    for _ in range(BRACKET_DOUBLINGS):
        if equivalent(hi) >= area:
            break
        hi *= 2.0
    return _bisect(equivalent, area, hi)
