"""The geometry primitives, each alone, against the independent float64 reference:
rays against one wall or one cylinder, a point's distance to a wall, one step's
displacement, the swept path's distance to one wall or one cylinder, angle wrapping;
then the maze-level swept distance built from them."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from jaxnav.world.geometry import (
    arc,
    arc_circle_clearance,
    arc_segment_clearance,
    displacement,
    min_over,
    path_clearance,
    point_segment_distance,
    ray_circle,
    ray_segment,
    wrap_angle,
)
from jaxnav.world.maps import BUILTIN_MAZES, make_maze, stack_mazes
from jaxnav.world.stages import STAGES

PI32 = float(np.float32(np.pi))  # float32's pi is a hair above the real one
HYP = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
TOL = 1e-4  # m, as the LiDAR tests


def f32(x):
    """Round to float32 and back: the value jaxnav actually sees."""
    return np.asarray(np.asarray(x, np.float32), np.float64)


def coord(lo=-2.0, hi=2.0):
    return st.floats(lo, hi).map(lambda x: float(np.float32(x)))


def point():
    return st.tuples(coord(), coord()).map(np.array)


@st.composite
def wall(draw):
    """A wall (4,) of length 5 cm to 3 m (mazes reject repeated vertices)."""
    ax, ay = draw(point())
    length, angle = draw(st.floats(0.05, 3.0)), draw(st.floats(-math.pi, math.pi))
    return f32([ax, ay, ax + length * math.cos(angle), ay + length * math.sin(angle)])


def circle():
    return st.tuples(coord(), coord(), coord(0.05, 1.0)).map(np.array)


angles = st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=8)


def aimed(origin, target, a):
    """The angles ``a`` and one more, towards ``target`` (so that rays do hit)."""
    return [*a, math.atan2(target[1] - origin[1], target[0] - origin[0])]


# ----------------------------------------------------------------------------
# Angles
# ----------------------------------------------------------------------------


def test_wrap_angle_at_the_float32_boundaries():
    xs = []
    for c in (-5, -3, -1, 1, 3, 5):
        x = np.float32(c * np.pi)
        lo = hi = x
        xs.append(x)
        for _ in range(64):
            lo = np.nextafter(lo, np.float32(-np.inf))
            hi = np.nextafter(hi, np.float32(np.inf))
            xs += [lo, hi]
    w = np.asarray(wrap_angle(jnp.asarray(np.array(xs, np.float32))))
    assert (w >= -PI32).all() and (w < PI32).all()
    np.testing.assert_allclose(np.cos(w), np.cos(np.array(xs, np.float64)), atol=1e-5)


@settings(max_examples=200, **HYP)
@given(x=st.floats(-40.0, 40.0))
def test_wrap_angle_matches_the_reference(x):
    x = np.float32(x)
    w = float(wrap_angle(jnp.float32(x)))
    assert -PI32 <= w < PI32
    want = float(ref.wrap(float(x)))
    assert abs(float(ref.wrap(w - want))) < 1e-5  # the same angle (either side of pi)


# ----------------------------------------------------------------------------
# Rays against one wall or one cylinder
# ----------------------------------------------------------------------------


def directions(angle_list):
    """float32 unit vectors of the angles, and the angles of those exact vectors."""
    a = np.asarray(angle_list, np.float64)
    dx, dy = np.float32(np.cos(a)), np.float32(np.sin(a))
    return dx, dy, np.arctan2(dy.astype(np.float64), dx.astype(np.float64))


def assume_well_conditioned(ref_fn, origin, exact, eps=1e-5):
    """Skip rays that graze (an end point, a tangent, a parallel wall): there a turn
    of eps rad, a few float32 roundings, changes the reading by more than 1 mm."""
    for turn in (-eps, eps):
        a, b = ref_fn(origin, exact), ref_fn(origin, exact + turn)
        assume(np.all(np.isinf(a) == np.isinf(b)))
        finite = np.isfinite(a)
        assume(np.all(np.abs(a[finite] - b[finite]) < 1e-3))


def assert_rays_agree(got, want):
    np.testing.assert_array_equal(np.isinf(got), np.isinf(want))
    finite = np.isfinite(want)
    np.testing.assert_allclose(got[finite], want[finite], atol=TOL)


_ray_segment = jax.jit(ray_segment)
_ray_circle = jax.jit(ray_circle)


@settings(max_examples=300, **HYP)
@given(origin=point(), w=wall(), a=angles, u=st.floats(0.0, 1.0))
def test_ray_segment_matches_the_reference(origin, w, a, u):
    assume(ref.point_wall(origin, w) > 1e-3)  # a ray from a wall touches it: 0 or a miss
    a = aimed(origin, w[:2] + u * (w[2:] - w[:2]), a)
    dx, dy, exact = directions(a)
    want = ref.ray_wall(origin, exact, w)
    assume_well_conditioned(lambda o, e: ref.ray_wall(o, e, w), origin, exact)
    got = np.asarray(_ray_segment(*np.float32(origin), dx, dy, *np.float32(w)))
    assert got.dtype == np.float32 and got.shape == (len(a),)
    assert_rays_agree(got, want)


def test_ray_segment_hits_the_facing_wall_and_misses_otherwise():
    # Wall x = 1 from y = -1 to 1; rays from the origin.
    dx = np.float32([1.0, -1.0, 0.0, math.cos(0.5)])
    dy = np.float32([0.0, 0.0, 1.0, math.sin(0.5)])
    got = np.asarray(_ray_segment(0.0, 0.0, dx, dy, 1.0, -1.0, 1.0, 1.0))
    np.testing.assert_allclose(got[[0, 3]], [1.0, 1.0 / math.cos(0.5)], rtol=1e-6)
    assert np.isinf(got[1]) and np.isinf(got[2])  # behind, and parallel


@settings(max_examples=300, **HYP)
@given(origin=point(), c=circle(), a=angles, off=point())
def test_ray_circle_matches_the_reference(origin, c, a, off):
    assume(abs(math.hypot(*(origin - c[:2])) - c[2]) > 1e-3)  # not from the edge itself
    a = aimed(origin, c[:2] + c[2] * off / 2, a)  # at a point within the circle's box
    dx, dy, exact = directions(a)
    want = ref.ray_cylinder(origin, exact, c)
    assume_well_conditioned(lambda o, e: ref.ray_cylinder(o, e, c), origin, exact)
    got = np.asarray(_ray_circle(*np.float32(origin), dx, dy, *np.float32(c)))
    assert got.dtype == np.float32 and got.shape == (len(a),)
    assert_rays_agree(got, want)


def test_ray_circle_from_outside_and_from_inside():
    # Circle at (2, 0), r = 0.5: from the origin the near edge; from its centre the
    # edge on the way out, whatever the direction.
    dx = np.float32([1.0, -1.0, 0.0])
    dy = np.float32([0.0, 0.0, 1.0])
    got = np.asarray(_ray_circle(0.0, 0.0, dx, dy, 2.0, 0.0, 0.5))
    assert got[0] == pytest.approx(1.5) and np.isinf(got[1]) and np.isinf(got[2])
    got = np.asarray(_ray_circle(2.0, 0.0, dx, dy, 2.0, 0.0, 0.5))
    np.testing.assert_allclose(got, 0.5, rtol=1e-6)


# ----------------------------------------------------------------------------
# A point and a wall
# ----------------------------------------------------------------------------

_point_segment = jax.jit(point_segment_distance)


@settings(max_examples=300, **HYP)
@given(p=point(), w=wall())
def test_point_segment_distance_matches_the_reference(p, w):
    got = float(_point_segment(*np.float32(p), *np.float32(w)))
    assert got == pytest.approx(ref.point_wall(p, w), abs=2e-6)


# ----------------------------------------------------------------------------
# One step of the unicycle
# ----------------------------------------------------------------------------

_displacement = jax.jit(displacement)


@settings(max_examples=300, **HYP)
@given(
    yaw=st.floats(-math.pi, math.pi),
    omega=st.floats(-3.0, 3.0),
    v=st.floats(0.0, 1.0),
    dt=st.floats(0.0, 2.0),
)
def test_displacement_is_the_integral_of_the_velocity(yaw, omega, v, dt):
    yaw, omega, v, dt = (np.float32(x) for x in (yaw, omega, v, dt))
    got = np.asarray(_displacement(yaw, omega, v, dt))
    want = ref.displacement(*(float(x) for x in (yaw, omega, v, dt)))
    assert got.dtype == np.float32 and got.shape == (2,)
    np.testing.assert_allclose(got, want, atol=1e-6)


@st.composite
def step_path(draw):
    """(pos, yaw, omega, v, dt) of a path of up to 1 m turning by up to 340 degrees,
    straight or with a turning radius of at most 10 m, all float32."""
    pos = draw(point())
    yaw = draw(st.floats(-math.pi, math.pi))
    v = draw(st.floats(0.05, 0.5))
    dt = draw(st.floats(0.2, 2.0))
    if draw(st.booleans()):
        omega = 0.0
    else:
        turn = draw(st.floats(0.05, 6.0)) * (1 if draw(st.booleans()) else -1)
        omega = turn / dt
        assume(abs(omega) >= 0.05)
    return pos, *(float(np.float32(x)) for x in (yaw, omega, v, dt))


def assert_swept(got, want, v, dt, n=4000):
    """Sampling overestimates the true minimum by at most half a sample spacing."""
    err = got - want
    assert err <= 2e-5, f"clearance above the sampled minimum by {err}"
    assert err >= -(v * dt / n / 2 + 2e-5), f"clearance below the sampled minimum by {-err}"


@jax.jit
def _arc_segment(pos, yaw, omega, v, dt, w):
    return arc_segment_clearance(arc(pos, yaw, omega, v, dt), w[0], w[1], w[2], w[3])


@jax.jit
def _arc_circle(pos, yaw, omega, v, dt, c):
    return arc_circle_clearance(arc(pos, yaw, omega, v, dt), c[0], c[1], c[2])


@settings(max_examples=300, **HYP)
@given(path=step_path(), w=wall())
def test_arc_segment_clearance_is_the_sampled_distance(path, w):
    pos, yaw, omega, v, dt = path
    got = float(_arc_segment(np.float32(pos), *np.float32([yaw, omega, v, dt]), np.float32(w)))
    assert_swept(got, ref.arc_wall_distance(pos, yaw, omega, v, dt, w), v, dt)


@settings(max_examples=300, **HYP)
@given(path=step_path(), c=circle())
def test_arc_circle_clearance_is_the_sampled_distance(path, c):
    pos, yaw, omega, v, dt = path
    got = float(_arc_circle(np.float32(pos), *np.float32([yaw, omega, v, dt]), np.float32(c)))
    assert_swept(got, ref.arc_cylinder_distance(pos, yaw, omega, v, dt, c), v, dt)


def test_a_path_crossing_a_wall_has_clearance_zero():
    # Half a turn of radius 0.5 around (0, 0.5) from the origin, through the wall y = 0.5.
    pos = jnp.zeros(2)
    w = jnp.asarray([-1.0, 0.5, 1.0, 0.5])
    for omega, dt in ((1.0, math.pi), (-1.0, math.pi), (0.0, 10.0)):
        yaw = 0.0 if omega else math.pi / 2
        got = float(_arc_segment(pos, yaw, omega, 0.5, dt, w))
        assert got == (0.0 if omega >= 0 else pytest.approx(0.5))


def test_min_over_skips_masked_rows_and_is_inf_when_none_is_left():
    table = jnp.asarray([[1.0, 5.0], [2.0, -3.0], [0.0, 1.0]])
    mask = jnp.asarray([True, False, True])

    def fn(a, b):
        return a + b * jnp.arange(3.0)  # f32[3] per row

    np.testing.assert_array_equal(np.asarray(min_over(fn, table, mask)), [0.0, 1.0, 2.0])
    got = min_over(fn, table, jnp.zeros(3, bool))
    assert got.shape == (3,) and np.isinf(np.asarray(got)).all()


# ----------------------------------------------------------------------------
# The maze: every wall and cylinder at once
# ----------------------------------------------------------------------------

CORRIDOR = str(Path(__file__).resolve().parents[1] / "configs" / "mazes" / "corridor.yaml")
# The mazes that stand still (the stages' moving cylinders: tests/test_moving.py).
STILL = [n for n in BUILTIN_MAZES if n not in STAGES]
NAMES = (*STILL, "corridor")


@functools.cache
def mazes():
    """(real mazes, the same padded to one shape): one compiled function serves all."""
    real = {n: make_maze(CORRIDOR if n == "corridor" else n) for n in NAMES}
    stacked = stack_mazes([real[n] for n in NAMES])
    padded = {n: jax.tree.map(lambda x, i=i: x[i], stacked) for i, n in enumerate(NAMES)}
    return real, padded


@functools.cache
def _swept_fn():
    return jax.jit(jax.vmap(path_clearance, in_axes=(None, 0, 0, 0, 0, 0)))


def swept(maze, pos, yaw, omega, v, dt):
    to = functools.partial(jnp.asarray, dtype=jnp.float32)
    return _swept_fn()(maze, to(pos), to(yaw), to(omega), to(v), to(dt))


@pytest.mark.parametrize("backward", [False, True])
@pytest.mark.parametrize("name", NAMES)
def test_path_clearance_is_the_exact_swept_distance(name, backward):
    """path_clearance against 2000 samples of the arc, on long arcs (up to 1 m and
    170 degrees) so that every case of the closed form comes up: a wall's foot point
    mid-arc, a wall's end vertex nearest, the arc crossing a wall, cylinders; driving
    forwards, and backing up (env.actions vw_reverse)."""
    real, padded = mazes()
    rng = np.random.default_rng(11)
    walls, circles = ref.maze_geometry(real[name])
    n = 250
    pos = f32(ref.sample_free(rng, real[name], n, 0.0))
    yaw = f32(rng.uniform(-np.pi, np.pi, n))
    dt = f32(rng.uniform(0.2, 2.0, n))
    omega = f32(rng.uniform(-1.0, 1.0, n) * 2.95 / dt)
    omega[: n // 10] = 0.0  # straight segments too
    v = f32(rng.uniform(0.05, 0.5, n) * (-1.0 if backward else 1.0))
    got = np.asarray(swept(padded[name], pos, yaw, omega, v, dt))
    want = ref.swept_distance_batch(pos, yaw, omega, v, dt, walls, circles, n=2000)
    # Sampling overestimates by at most half a sample spacing (<= 2.5e-4 m here).
    step = np.abs(v) * dt / 2000
    err = got - want
    assert (err <= 2e-5).all(), f"{name}: path_clearance above the sampled minimum by {err.max()}"
    assert (err >= -(step / 2 + 2e-5)).all(), f"{name}: path_clearance too small by {-err.min()}"
    least = 0.05 if backward else 0.1  # of arcs that collide, and that do not
    assert (want < 0.13).mean() > least and (want > 0.13).mean() > least
