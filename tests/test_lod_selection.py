"""The LOD-selection API on arguments an engine may send by mistake: a camera at or inside the object, a NaN
from a division upstream, a zero viewport. Each was a numpy warning and an arbitrary LOD; now a camera at
distance <= 0 draws LOD 0 and a meaningless argument is a ValueError naming it."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import swpm_usd
from swpm_usd.encode import slidingwindow
from swpm_usd.encode.base import lod_at_error
from swpm_usd.encode.slidingwindow import screen_space_error
from swpm_usd.mesh import Mesh

ENCODINGS = ["vanilla", "skip-strip", "mixed", "sliding-window"]


def _flat_grid(n: int = 8) -> Mesh:
    """A flat square of (n-1)^2 quads: most of its collapses move no point off the plane, so many LODs after
    LOD 0 have error 0 (a camera at distance 0 picked the last of them)."""
    xs, ys = np.meshgrid(np.arange(n), np.arange(n))
    pts = np.c_[xs.ravel(), ys.ravel(), np.zeros(n * n)].astype(np.float32)
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    tris = np.concatenate([np.c_[a, a + 1, a + n], np.c_[a + 1, a + n + 1, a + n]]).astype(np.int32)
    return Mesh(pts, tris)


@pytest.fixture(scope="module")
def grid_pms():
    mesh = _flat_grid()
    return {enc: swpm_usd.build(mesh, encoding=enc) for enc in ENCODINGS}


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_a_camera_at_or_inside_the_object_draws_lod_0(grid_pms, encoding):
    pm = grid_pms[encoding]
    assert int((pm.lod_errors == 0).sum()) > 1  # (the case: LODs after 0 of no error)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (distance 0 divided by zero: a RuntimeWarning)
        for distance in (0.0, -0.0, -5.0):
            assert pm.lod_for_screen_error(1.0, distance, 1.0, 1080) == 0
            if encoding == "sliding-window":
                rec = pm.record_for_screen_error(1.0, distance, 1.0, 1080)
                assert np.array_equal(rec, pm.window_records[0])
        assert screen_space_error(0.5, 0.0, 1.0, 1080) == math.inf
        assert screen_space_error(0.0, 0.0, 1.0, 1080) == 0.0
        # a camera farther than any error matters (a distance whose product overflows) draws the coarsest
        assert pm.lod_for_screen_error(1.0, 1e308, 3.0, 1080) == pm.lod_count - 1


BAD_VIEWS = [
    ({"max_pixels": float("nan")}, "max_pixels"),
    ({"max_pixels": -1.0}, "max_pixels"),
    ({"max_pixels": math.inf}, "max_pixels"),
    ({"distance": float("nan")}, "distance"),
    ({"distance": math.inf}, "distance"),
    ({"fov_y": 0.0}, "fov_y"),
    ({"fov_y": -0.5}, "fov_y"),
    ({"fov_y": math.pi}, "fov_y"),
    ({"fov_y": 4.0}, "fov_y"),
    ({"fov_y": float("nan")}, "fov_y"),
    ({"viewport_height": 0}, "viewport_height"),
    ({"viewport_height": -1080}, "viewport_height"),
    ({"viewport_height": float("inf")}, "viewport_height"),
]


@pytest.mark.parametrize(
    ("bad", "name"), BAD_VIEWS, ids=[f"{n}={next(iter(b.values()))}" for b, n in BAD_VIEWS]
)
def test_a_meaningless_view_is_a_value_error_naming_the_argument(grid_pms, bad, name):
    args = {"max_pixels": 1.0, "distance": 10.0, "fov_y": 1.0, "viewport_height": 1080} | bad
    for encoding in ENCODINGS:
        pm = grid_pms[encoding]
        with pytest.raises(ValueError, match=name):
            pm.lod_for_screen_error(**args)
    with pytest.raises(ValueError, match=name):
        grid_pms["sliding-window"].record_for_screen_error(**args)
    if name != "max_pixels":
        with pytest.raises(ValueError, match=name):
            slidingwindow.screen_space_error(0.1, args["distance"], args["fov_y"], args["viewport_height"])


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_error_and_triangle_budgets_take_numbers_at_least_0(grid_pms, encoding):
    pm = grid_pms[encoding]
    for bad in (float("nan"), -1.0, -1e-30):
        with pytest.raises(ValueError, match="max_error"):
            pm.lod_for_error(bad)  # -1.0 was LOD 0, NaN a ValueError without the name
        with pytest.raises(ValueError, match="target"):
            pm.lod_for_triangles(bad)  # -1.0 was the coarsest LOD
    with pytest.raises(ValueError, match="target"):
        pm.lod_for_triangles(-1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # (np.float32 of 1e39 warned of an overflow)
        assert pm.lod_for_error(1e39) == pm.lod_for_error(math.inf) == pm.lod_count - 1
    assert pm.lod_for_triangles(math.inf) == 0  # was an OverflowError
    assert pm.lod_for_triangles(10**30) == 0
    t0 = pm.triangle_count_at(0)
    # a fraction of a triangle rounds down, as int() did
    assert pm.lod_for_triangles(t0 - 0.5) == pm.lod_for_triangles(t0 - 1)
    if encoding == "sliding-window":
        with pytest.raises(ValueError, match="target"):
            pm.record_for_triangles(float("nan"))
        with pytest.raises(ValueError, match="max_error"):
            pm.record_for_error(-1.0)


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_numpy_0d_arrays_and_integers_past_float_range_are_numbers(grid_pms, encoding):
    """A 0-d array (what ``np.asarray`` or a reduction with ``keepdims`` hands an engine) picked as its value
    does on main; a TypeError "must be a number" refused it. A Python integer past float's range is no
    OverflowError: ``lod_for_triangles(10**400)`` is LOD 0 as on main, ``lod_for_error`` the coarsest, and a
    view argument that large a ValueError naming it."""
    pm = grid_pms[encoding]
    assert pm.lod_for_error(np.array(0.5)) == pm.lod_for_error(0.5)
    assert pm.lod_for_triangles(np.array(40)) == pm.lod_for_triangles(40)
    view = (np.array(1.0), np.array(10.0), np.array(1.0), np.array(1080))
    assert pm.lod_for_screen_error(*view) == pm.lod_for_screen_error(1.0, 10.0, 1.0, 1080)
    assert screen_space_error(np.array(0.5), *view[1:]) == screen_space_error(0.5, 10.0, 1.0, 1080)
    if encoding == "sliding-window":
        rec = pm.record_for_screen_error(*view)
        assert np.array_equal(rec, pm.record_for_screen_error(1.0, 10.0, 1.0, 1080))
    with pytest.raises(ValueError, match="max_error"):
        pm.lod_for_error(np.array(float("nan")))
    assert pm.lod_for_triangles(10**400) == 0
    assert pm.lod_for_error(10**400) == pm.lod_count - 1
    with pytest.raises(ValueError, match="target"):
        pm.lod_for_triangles(-(10**400))
    with pytest.raises(ValueError, match="distance"):
        pm.lod_for_screen_error(1.0, 10**400, 1.0, 1080)
    with pytest.raises(ValueError, match="max_pixels"):
        pm.lod_for_screen_error(10**400, 10.0, 1.0, 1080)
    with pytest.raises(TypeError, match="max_error"):
        pm.lod_for_error(np.array([0.5, 1.0]))  # (an array of several values is no budget)


def _bumpy_grid(n: int = 8) -> Mesh:
    """:func:`_flat_grid` lifted off its plane: its LODs have distinct positive errors."""
    mesh = _flat_grid(n)
    pts = mesh.points.copy()
    pts[:, 2] = np.sin(pts[:, 0] * 1.3) * np.cos(pts[:, 1] * 0.7)
    return Mesh(pts, mesh.triangles)


def _just_below(e: np.float32) -> float:
    """A float64 below the float32 ``e`` that np.float32 rounds up to ``e``: just above the midpoint of ``e``
    and the float32 before it."""
    below = np.nextafter(e, np.float32(0))
    x = float(np.nextafter((float(below) + float(e)) / 2, math.inf))
    assert x < float(e) and np.float32(x) == e  # (the case: rounded to nearest, the bound is e)
    return x


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_an_lod_whose_float32_error_is_above_the_bound_is_not_picked(encoding):
    """``lod_for_error(x)`` is the last LOD whose error is <= x, x a float64 and the errors float32: x was
    rounded to the nearest float32, up when it lay in the upper half of the ulp below an error, and the LOD
    of that error, 1 ulp of float32 above x, was picked. The bound is the largest float32 <= x."""
    pm = swpm_usd.build(_bumpy_grid(), encoding=encoding)
    errors = pm.lod_errors
    steps = [k for k in range(1, pm.lod_count) if errors[k] > errors[k - 1]]
    assert len(steps) > 5
    for k in steps:
        x = _just_below(errors[k])
        expected = int(np.flatnonzero(errors.astype(np.float64) <= x)[-1])
        assert expected < k
        assert pm.lod_for_error(x) == expected
        assert pm.lod_for_error(float(errors[k])) >= k  # (an error equal to the bound still passes)
        if encoding == "sliding-window":
            assert np.array_equal(pm.record_for_error(x), pm.window_records[expected])


def test_a_callers_float64_errors_are_compared_with_the_bound_unrounded():
    """``record_for_error``'s own ``lod_errors``, given as float64, are compared exactly: rounded to float32
    (as they were), an error just above the bound became the bound itself, and its LOD was picked."""
    pm = swpm_usd.build(_bumpy_grid(), encoding="sliding-window")
    errors = pm.lod_errors.astype(np.float64)
    k = pm.lod_count // 2
    bound = float(np.float32(errors[k]))
    errors[k:] = np.maximum(errors[k:], np.nextafter(bound, math.inf))  # (k on: just above the bound)
    assert np.array_equal(pm.record_for_error(bound, errors), pm.window_records[k - 1])
    # (rounded to float32, LOD k's error is the bound itself: the case)
    assert np.float32(errors[k]) == np.float32(bound)


def test_the_float32_bound_at_float32_s_edges_and_errors_of_other_types():
    """``lod_at_error`` at the edges of float32 (its subnormals, -0.0, its largest value and past it: no
    overflow warning) and for a caller's errors of other types (float16, float64, integers: compared
    exactly, not with a bound rounded to float32). Each bound below lies under an error that rounding to
    the nearest float32 made it equal to (that LOD was picked)."""
    tiny, big = np.finfo(np.float32).smallest_subnormal, np.finfo(np.float32).max
    errors = np.array([0.0, tiny, 1.0, big], np.float32)
    ulp_of_big = float(big) - float(np.nextafter(big, np.float32(0)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert lod_at_error(errors, -0.0) == 0
        assert lod_at_error(errors, float(tiny) * 0.75) == 0  # (np.float32 of it: tiny)
        assert lod_at_error(errors, float(tiny)) == 1
        assert lod_at_error(errors, float(big) - ulp_of_big / 4) == 2  # (np.float32 of it: big)
        assert (
            lod_at_error(errors, float(big))
            == lod_at_error(errors, 1e39)
            == lod_at_error(errors, math.inf)
            == 3
        )
        for other in (np.float16, np.float64, np.int64):
            e = np.array([0, 1, 2], other)
            assert lod_at_error(e, math.nextafter(1.0, 0.0)) == 0  # (np.float32 of it: 1.0)
            assert lod_at_error(e, 1.0) == 1
        half = np.array([0, 0.1, 0.2], np.float16)  # (0.1 as float16 is 0.0999755859375)
        assert lod_at_error(half, math.nextafter(float(half[1]), 0.0)) == 0
        assert lod_at_error(half, 0.1) == 1
