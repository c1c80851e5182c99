"""The perspective projection of an object-space error to pixels, and the checks of a LOD query's arguments:
one formula for :meth:`.ProgressiveMesh.lod_for_screen_error`, the sliding window's
``record_for_screen_error`` and :func:`screen_space_error`.

A query's arguments come from an engine each frame: a NaN there (a division by a zero somewhere upstream)
picked an arbitrary LOD with a numpy warning, and a camera at distance 0 divided by zero. Now a meaningless
argument is a :class:`ValueError` naming it, and a camera at or inside the object (``distance <= 0``) draws
full detail.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = ["budget", "error_for_pixels", "screen_space_error"]


def _shown(v: float) -> str:
    """``v`` as a message shows it: ``NaN`` (the word a search finds), else its repr."""
    return "NaN" if math.isnan(v) else repr(v)


def _real(name: str, value: float) -> float:
    """``value`` as a float, else a :class:`TypeError` naming ``name``. A numpy scalar or 0-d array is its
    value (0.7.4 took them: ``np.asarray`` or a ``keepdims`` reduction hands an engine one); an integer past
    float's range is ``inf`` of its sign (``float()`` raised OverflowError)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def budget(name: str, value: float) -> float:
    """``value`` as a float: a real number, not NaN and not negative (``inf`` allowed: no limit), else a
    :class:`ValueError` (a :class:`TypeError` for a non-number) naming ``name``."""
    v = _real(name, value)
    if not v >= 0.0:  # (NaN fails every comparison)
        raise ValueError(f"{name} must be a number >= 0, got {_shown(v)}")
    return v


def _view(distance: float, fov_y: float, viewport_height: float) -> tuple[float, float, float]:
    """The view's arguments as floats, each checked: finite, ``fov_y`` in (0, pi), ``viewport_height > 0``."""
    out = []
    for name, value in (("distance", distance), ("fov_y", fov_y), ("viewport_height", viewport_height)):
        v = _real(name, value)
        if not math.isfinite(v):
            raise ValueError(f"{name} must be finite, got {_shown(v)}")
        out.append(v)
    d, fov, height = out
    if not 0.0 < fov < math.pi:  # (NaN is not finite: refused above)
        raise ValueError(f"fov_y must be in (0, pi) radians, got {fov!r}")
    if not height > 0.0:
        raise ValueError(f"viewport_height must be > 0 pixels, got {height!r}")
    return d, fov, height


def _project(error: float, distance: float, fov_y: float, viewport_height: float) -> float:
    """Pixels ``error`` mesh units cover at ``distance > 0`` (checked floats): the one formula."""
    # (Python floats, whose overflow is inf without a numpy warning; np.tan as the formula always took it)
    denom = 2.0 * distance * float(np.tan(0.5 * fov_y))
    if denom == 0.0:  # (a distance or fov_y so small that the product underflows)
        return math.inf if error > 0.0 else 0.0
    return error * viewport_height / denom


def screen_space_error(error: float, distance: float, fov_y: float, viewport_height: int) -> float:
    """Pixels covered by an object-space ``error`` (>= 0) at ``distance`` (perspective, vertical field of
    view ``fov_y`` in radians, in (0, pi), on a viewport ``viewport_height`` > 0 pixels high). At
    ``distance <= 0`` (the camera at or inside the object) a non-zero error covers ``inf`` pixels, no error
    none. A NaN, negative or infinite argument is a :class:`ValueError` naming it."""
    e = budget("error", error)
    if math.isinf(e):
        raise ValueError(f"error must be finite, got {e!r}")
    d, fov, height = _view(distance, fov_y, viewport_height)
    if d <= 0.0:
        return math.inf if e > 0.0 else 0.0
    return _project(e, d, fov, height)


def error_for_pixels(max_pixels: float, distance: float, fov_y: float, viewport_height: int) -> float | None:
    """The largest object-space error that projects to at most ``max_pixels`` (finite, >= 0) at ``distance``
    (:func:`screen_space_error`'s view); None at ``distance <= 0``: the camera at or inside the object, where
    only LOD 0 is right (a later LOD whose error rounds to 0 in float32 may still differ from it). A NaN,
    negative or infinite argument is a :class:`ValueError` naming it."""
    px = budget("max_pixels", max_pixels)
    if math.isinf(px):
        raise ValueError(f"max_pixels must be finite, got {px!r}")
    d, fov, height = _view(distance, fov_y, viewport_height)
    if d <= 0.0:
        return None
    # (over the pixels of one unit, as both copies of the formula computed it: the same picks bit for bit)
    per_unit = _project(1.0, d, fov, height)
    return px / per_unit if per_unit > 0.0 else math.inf  # (0: a distance so large the product overflows)
