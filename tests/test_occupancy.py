"""Occupancy-grid worlds: the grid LiDAR against a brute-force NumPy caster and a map
computed by hand, the swept disc against a NumPy disc-vs-cell check, ROS map files
(their pixels, their keys, every bad file in one line) and the environment in one."""

from __future__ import annotations

import functools
import math

import _nav_reference as ref
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxnav
import jaxnav.commands.evaluate as evaluate_command
from jaxnav.core.errors import MazeError
from jaxnav.world import occupancy as oc
from jaxnav.world.geometry import arc
from jaxnav.world.maps import make_maze, stack_mazes

FLAT = "configs/mazes/flat.yaml"


def cell_geometry(occ, origin, res, disc):
    """The occupied cells as the reference's walls (a square's 4 sides) or circles."""
    walls, circles = [], []
    for i, j in zip(*np.nonzero(occ)):
        x0, y0 = origin[0] + j * res, origin[1] + i * res
        x1, y1 = x0 + res, y0 + res
        if disc:
            circles.append([x0 + res / 2, y0 + res / 2, disc])
        else:
            walls += [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]
    return np.array(walls, float).reshape(-1, 4), np.array(circles, float).reshape(-1, 3)


def solid_at(occ, origin, res, pts):
    """bool[P]: the points lie inside an occupied square."""
    j = np.floor((pts[:, 0] - origin[0]) / res).astype(int)
    i = np.floor((pts[:, 1] - origin[1]) / res).astype(int)
    ok = (i >= 0) & (i < occ.shape[0]) & (j >= 0) & (j < occ.shape[1])
    out = np.zeros(len(pts), bool)
    out[ok] = occ[i[ok], j[ok]]
    return out


@functools.cache
def _ranges_fn():
    def one(grid, p, a):
        return oc.grid_ranges(grid, p, jnp.stack([jnp.cos(a), jnp.sin(a)], -1))

    return jax.jit(jax.vmap(one, in_axes=(None, 0, 0)))


@pytest.mark.parametrize("disc", [0.0, 0.5, 0.3])  # squares; discs of res / 2, of 0.3 res
def test_grid_scan_equals_a_brute_force_caster_on_random_grids(disc):
    rng = np.random.default_rng(int(disc * 10) + 1)
    for _ in range(6):
        h, w = rng.integers(3, 30, 2)
        res = float(rng.choice([0.05, 0.15, 0.3]))
        occ = rng.random((h, w)) < rng.uniform(0.05, 0.5)
        origin = rng.uniform(-2, 2, 2)
        grid = oc.make_occupancy(occ, origin, res, disc * res)
        walls, circles = cell_geometry(occ, origin, res, disc * res)
        # origins inside and around the grid, off every square and clear of every disc
        pts = origin + rng.uniform(-0.3, 1.3, (60, 2)) * np.array([w * res, h * res])
        clear = ref.clearance(pts, walls, circles) if occ.any() else np.ones(len(pts))
        pts = pts[(clear > 1e-3) & ~(solid_at(occ, origin, res, pts) & (disc == 0))]
        angles = rng.uniform(-np.pi, np.pi, (len(pts), 32))
        want = ref.ray_distances(pts, angles, walls, circles)
        got = np.asarray(
            _ranges_fn()(grid, jnp.asarray(pts, jnp.float32), angles.astype(np.float32))
        )
        assert np.array_equal(np.isfinite(got), np.isfinite(want))
        near = np.isfinite(want) & (want < oc.DEFAULT_RANGE)
        np.testing.assert_allclose(got[near], want[near], atol=1e-4)


@pytest.mark.parametrize("disc", [0.0, 0.5])
def test_grid_scan_is_exact_to_the_sensors_range_at_every_heading(disc):
    # a sparse grid wider than the sensor's reach: the walk stops at the lines the range
    # needs, so beams along an axis, along a diagonal and at random headings, from near
    # cell corners, inside cells and anywhere, must all still find every cell they enter
    # within range (clipped there, against the brute-force caster). Starts 1-2 mm off
    # the lattice: a beam exactly along a lattice line only grazes the cells beside it,
    # where the caster and the walk may differ by convention.
    rng = np.random.default_rng(7)
    res, sensor = 0.05, 2.0
    occ = rng.random((120, 120)) < 0.01
    origin = np.array([-3.0, -3.0])
    grid = oc.fit(oc.make_occupancy(occ, origin, res, disc * res), sensor, 0.5)
    walls, circles = cell_geometry(occ, origin, res, disc * res)
    corners = origin + res * rng.integers(30, 90, (20, 2)).astype(float) + [1e-3, 2e-3]
    on_lines = corners + np.array([0.5 * res, 0.3 * res])
    anywhere = origin + rng.uniform(1.5, 4.5, (20, 2))
    pts = np.concatenate([corners, on_lines, anywhere])
    clear = ref.clearance(pts, walls, circles)
    pts = pts[(clear > 1e-3) & ~(solid_at(occ, origin, res, pts) & (disc == 0))]
    fixed = np.arange(8) * np.pi / 4  # along the axes and the diagonals
    angles = np.concatenate(
        [np.broadcast_to(fixed, (len(pts), 8)), rng.uniform(-np.pi, np.pi, (len(pts), 24))], 1
    )
    want = np.minimum(ref.ray_distances(pts, angles, walls, circles), sensor)
    got = np.asarray(_ranges_fn()(grid, jnp.asarray(pts, jnp.float32), angles.astype(np.float32)))
    assert (want < sensor).mean() > 0.3  # the beams meet cells within range, and miss
    np.testing.assert_allclose(np.minimum(got, sensor), want, atol=1e-4)


def test_grid_scan_on_a_map_computed_by_hand():
    # 4 x 5 cells of 0.5 m from (0, 0); occupied: (row 1, col 3) and the top row's col 0.
    occ = np.zeros((4, 5), bool)
    occ[1, 3] = True
    occ[3, 0] = True
    grid = oc.make_occupancy(occ, (0.0, 0.0), 0.5)
    pos = jnp.asarray([0.25, 0.75])  # centre of cell (1, 0)
    slant = math.atan2(1.0, 0.2)  # north, a little east: meets cell (3, 0) at y = 1.5
    angles = jnp.asarray([0.0, math.pi / 2, math.pi, -math.pi / 2, slant])
    got = np.asarray(_ranges_fn()(grid, pos[None], angles[None]))[0]
    # east: cell (1, 3) starts at x = 1.5: 1.25 m; north: cell (3, 0) starts at y = 1.5:
    # 0.75 m; west and south: nothing (the grid ends, nothing beyond); the slanted ray
    # rises 0.75 m at a slope of 5 (0.15 m east, inside column 0): 0.75 sqrt(1.04) m.
    slanted = 0.75 * math.sqrt(1.04)
    np.testing.assert_allclose(got, [1.25, 0.75, np.inf, np.inf, slanted], atol=1e-6)
    discs = oc.make_occupancy(occ, (0.0, 0.0), 0.5, 0.2)
    got = np.asarray(_ranges_fn()(discs, pos[None], angles[None]))[0]
    # the discs of (1, 3) and (3, 0) are centred at (1.75, 0.75) and (0.25, 1.75), radius
    # 0.2; the slanted ray passes (0.25, 1.75) at 0.2 / sqrt(1.04) from its centre, so it
    # meets the disc sqrt(0.2^2 - 0.04 / 1.04) before its nearest point, 1 / sqrt(1.04) on.
    gap = 0.2 / math.sqrt(1.04)
    slanted = 1.0 / math.sqrt(1.04) - math.sqrt(0.2**2 - gap**2)
    np.testing.assert_allclose(got, [1.3, 0.8, np.inf, np.inf, slanted], atol=1e-6)


def _swept_to_cells(occ, origin, res, disc, pos, yaw, omega, v, dt, n=4001):
    """NumPy: the least distance from n points of the step's exact path to the cells
    (a point's distance to a square, or to a disc's centre less its radius)."""
    s = np.linspace(0.0, dt, n)
    if abs(omega) < 1e-9:
        px, py = pos[0] + v * s * np.cos(yaw), pos[1] + v * s * np.sin(yaw)
    else:
        r = v / omega
        px = pos[0] + r * (np.sin(yaw + omega * s) - np.sin(yaw))
        py = pos[1] - r * (np.cos(yaw + omega * s) - np.cos(yaw))
    rows, cols = np.nonzero(occ)
    cx = origin[0] + (cols + 0.5) * res
    cy = origin[1] + (rows + 0.5) * res
    dx, dy = px[:, None] - cx[None], py[:, None] - cy[None]
    if disc:
        d = np.hypot(dx, dy) - disc
    else:
        d = np.hypot(np.maximum(np.abs(dx) - res / 2, 0), np.maximum(np.abs(dy) - res / 2, 0))
    return float(d.min(initial=np.inf))


@pytest.mark.slow  # 3 s on 2 cores
@pytest.mark.parametrize("disc", [0.0, 0.5])
def test_swept_disc_against_every_cell_equals_a_numpy_check(disc):
    rng = np.random.default_rng(7 + int(disc * 10))
    fn = jax.jit(
        jax.vmap(
            lambda g, p, y, w, v: oc.grid_clearance(g, arc(p, y, w, v, 0.2)), (None, 0, 0, 0, 0)
        )
    )
    for _ in range(5):
        h, w = rng.integers(4, 20, 2)
        res = float(rng.choice([0.05, 0.15]))
        occ = rng.random((h, w)) < 0.25
        origin = rng.uniform(-1, 1, 2)
        grid = oc.fit(oc.make_occupancy(occ, origin, res, disc * res), 3.5, 0.6)
        pts = origin + rng.uniform(0, 1, (60, 2)) * np.array([w * res, h * res])
        walls, circles = cell_geometry(occ, origin, res, disc * res)
        free = ref.clearance(pts, walls, circles) > 0.01
        pts = pts[free & ~(solid_at(occ, origin, res, pts) & (disc == 0))]
        yaw = rng.uniform(-np.pi, np.pi, len(pts))
        omega = rng.choice([-2.8, -1.5, 0.0, 0.75, 1.5, 2.8], len(pts))
        v = rng.uniform(0.0, 0.5, len(pts))
        got = np.asarray(fn(grid, *(jnp.asarray(x, jnp.float32) for x in (pts, yaw, omega, v))))
        for k in range(len(pts)):
            want = _swept_to_cells(
                occ, origin, res, disc * res, pts[k], yaw[k], omega[k], v[k], 0.2
            )
            cap = (grid.window - 1) * res - v[k] * 0.2
            assert got[k] == pytest.approx(min(want, cap), abs=2e-5), (pts[k], yaw[k], omega[k])


def test_point_clearance_is_each_points_distance_to_the_cells():
    rng = np.random.default_rng(3)
    occ = rng.random((12, 9)) < 0.3
    grid = oc.fit(oc.make_occupancy(occ, (0.0, 0.0), 0.1), 3.5, 0.5)
    pts = rng.uniform(-0.2, 1.3, (200, 2))
    got = np.asarray(oc.point_clearance(grid, *jnp.asarray(pts.T, jnp.float32)))
    rows, cols = np.nonzero(occ)
    dx = np.abs(pts[:, None, 0] - (cols + 0.5) * 0.1) - 0.05
    dy = np.abs(pts[:, None, 1] - (rows + 0.5) * 0.1) - 0.05
    want = np.hypot(np.maximum(dx, 0), np.maximum(dy, 0)).min(axis=1)
    np.testing.assert_allclose(got, np.minimum(want, (grid.window - 1) * 0.1), atol=1e-5)


def test_grid_outline_walls_are_the_sides_between_occupied_and_free_cells():
    occ = np.array([[1, 1, 0], [0, 1, 0]], bool)
    walls = oc.grid_walls(oc.make_occupancy(occ, (0.0, 0.0), 1.0))
    total = float(np.hypot(walls[:, 2] - walls[:, 0], walls[:, 3] - walls[:, 1]).sum())
    assert total == 8.0  # the L of three unit squares has a perimeter of 8
    assert len(walls) == 6  # its six straight sides, joined along each line


def write_map(tmp_path, pixels, **keys):
    """A ROS map: an 8-bit PGM of ``pixels`` (row 0 the top) and its YAML."""
    h, w = pixels.shape
    (tmp_path / "m.pgm").write_bytes(
        b"P5\n%d %d\n255\n" % (w, h) + pixels.astype(np.uint8).tobytes()
    )
    doc = {"image": "m.pgm", "resolution": 0.1, "origin": [0.0, 0.0, 0.0], **keys}
    lines = [f"{k}: {v}" for k, v in doc.items()]
    (tmp_path / "m.yaml").write_text("\n".join(lines) + "\n")
    return str(tmp_path / "m.yaml")


def open_room(n=20):
    """n x n pixels: a free room inside one dark pixel of wall."""
    px = np.full((n, n), 254)
    px[0], px[-1], px[:, 0], px[:, -1] = 0, 0, 0, 0
    return px


def test_ros_map_pixels_land_where_map_server_puts_them(tmp_path):
    px = open_room()
    px[2, 15] = 0  # image row 2 from the top: the map's row 17 from the bottom
    px[15, 3] = 205  # unknown grey: a wall
    keys = {"origin": "[-1.0, 2.0, 0.0]", "start": "[0.5, 3.0, 0.0]"}
    maze = make_maze(write_map(tmp_path, px, **keys))
    occ = np.asarray(maze.grid.occupied)[1:-1, 1:-1]  # within the laid-around wall
    assert occ.shape == (20, 20) and occ[17, 15] and occ[4, 3] and not occ[10, 10]
    assert np.asarray(maze.grid.occupied)[0].all()  # beyond the image: a wall
    # cell (17, 15) spans x in [-1 + 1.5, -1 + 1.6], y in [2 + 1.7, 2 + 1.8]
    o = np.asarray(maze.grid.origin) + 0.1  # the image's own corner
    np.testing.assert_allclose(o, [-1.0, 2.0], atol=1e-6)
    negated = make_maze(write_map(tmp_path, 255 - px, negate=1, **keys))
    assert np.array_equal(np.asarray(negated.grid.occupied), np.asarray(maze.grid.occupied))


def test_ros_map_default_start_is_the_roomiest_free_point(tmp_path):
    maze = make_maze(write_map(tmp_path, open_room()))
    np.testing.assert_allclose(np.asarray(maze.start)[:2], [1.0, 1.0], atol=0.05)


BAD = [
    ({"image": "missing.pgm"}, "not found"),
    ({"resolution": 0}, "resolution must be a positive"),
    ({"resolution": -0.05}, "resolution must be a positive"),
    ({"origin": "[0, 0, 0.5]"}, "rotated map"),
    ({"mode": "fancy"}, "mode must be"),
    ({"free_thresh": 0.9}, "must not exceed"),
    ({"start": "[0.05, 0.05, 0.0]"}, "inside a wall"),
    ({"colour": 1}, "unknown key"),
]


@pytest.mark.parametrize("keys,says", BAD)
def test_a_bad_ros_map_is_refused_in_one_line(tmp_path, keys, says):
    with pytest.raises(MazeError, match=says) as e:
        make_maze(write_map(tmp_path, open_room(), **keys))
    assert "\n" not in str(e.value)


def test_unsupported_images_and_rooms_without_space_are_refused(tmp_path):
    (tmp_path / "m.jpg").write_bytes(b"\xff\xd8\xff")
    (tmp_path / "j.yaml").write_text("image: m.jpg\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MazeError, match="not a PGM or PNG"):
        make_maze(str(tmp_path / "j.yaml"))
    (tmp_path / "x.pgm").write_bytes(b"P5\nnot an image")
    (tmp_path / "x.yaml").write_text("image: x.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(MazeError, match="cannot be read"):
        make_maze(str(tmp_path / "x.yaml"))
    tiny = open_room(6)  # 0.4 m of room: no goal 0.35 m clear of its walls
    with pytest.raises(MazeError, match="no free cell reachable"):
        make_maze(write_map(tmp_path, tiny, start="[0.3, 0.3, 0.0]"))


def test_a_bad_map_on_the_command_line_is_one_line_exit_2_and_nothing_written(tmp_path, capsys):
    bad = write_map(tmp_path, open_room(), resolution=0)
    out = tmp_path / "out"
    assert evaluate_command.main(["--baseline", "dwa", bad, "--seeds", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "resolution must be a positive" in err and "\n" not in err
    assert not out.exists()


def test_the_robot_cannot_drive_through_a_wall_of_the_example_map():
    env, params = jaxnav.make(FLAT)
    assert params.maze.grid is not None and env.grid_fit[0] == float(params.max_range)
    _, state = env.reset(jax.random.PRNGKey(0), params)
    # the start faces the left room's east wall (x = -0.05), 2.15 m ahead: straight on
    step = jax.jit(env.step_env)
    collided, steps = False, 0
    while not collided and steps < 200:
        _, state, _, _, _, info = step(jax.random.PRNGKey(steps), state, 2, params)
        collided, steps = bool(info["collision"]), steps + 1
    assert collided
    # it stopped where its disc met the wall, not beyond: 2.15 - 0.13 m in 0.03 m steps
    assert float(state.pos[0]) <= -0.05 - 0.13 + 0.03 + 1e-4
    assert steps == math.ceil((2.15 - 0.13) / 0.03)


def test_grid_mazes_stack_padded_with_free_cells():
    a = make_maze(FLAT)
    b = a.replace(grid=a.grid.replace(occupied=a.grid.occupied[:50, :60]))
    stacked = stack_mazes([a, b])
    assert stacked.grid.occupied.shape == (2, *a.grid.shape)
    assert not np.asarray(stacked.grid.occupied)[1, 50:].any()


def test_a_map_too_large_for_memory_at_the_batch_is_refused_before_training(tmp_path, capsys):
    import jaxnav.commands.train as train_command

    out = tmp_path / "run"
    argv = ["smoke", f"env.maze={FLAT}", "agent=pqn", "preset=modern", "pqn.num_envs=4000000"]
    assert train_command.main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "grid's LiDAR walk" in err and "\n" not in err
    assert not out.exists()
