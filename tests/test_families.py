"""The cylinders and rooms maze families: the raster and its shortest paths against
NumPy references, starts and goals clear of everything and joined by a free path,
the train/test split, the fallback of an exhausted draw, and the settings' limits."""

from __future__ import annotations

import heapq
import math
from collections import deque

import _nav_reference as ref
import jax
import numpy as np
import pytest

from jaxnav.core import families as registry
from jaxnav.core.errors import ConfigError
from jaxnav.world import cylinders, draws, maps, rooms
from jaxnav.world import generators as gen

CYL = cylinders.Cylinders(8, 0.1, 0.25, 4.0, 1.5)
ROOMS = rooms.Rooms(3, 3, 1.5, 0.5, 0.2, 2)
KEYS = jax.random.split(jax.random.PRNGKey(5), 48)


def dijkstra(free: np.ndarray, src: int, n: int) -> np.ndarray:
    """NumPy/heapq Dijkstra over an n x n raster (8 neighbours, steps 1 and sqrt 2, in
    cells): distance from ``src`` to every cell, inf where unreached."""
    dist = np.full(n * n, np.inf)
    dist[src] = 0.0
    heap = [(0.0, src)]
    while heap:
        d, u = heapq.heappop(heap)
        if d > dist[u]:
            continue
        r, c = divmod(u, n)
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if (dr or dc) and 0 <= rr < n and 0 <= cc < n and free[rr * n + cc]:
                    nd = d + (math.sqrt(2) if dr and dc else 1.0)
                    if nd < dist[rr * n + cc]:
                        dist[rr * n + cc] = nd
                        heapq.heappush(heap, (nd, rr * n + cc))
    return dist


def raster_reachable(walls, circles, lo, hi, start, goal, cell=0.05) -> bool:
    """Whether a robot disc gets from ``start`` to ``goal``: breadth-first search over a
    float64 raster of ``cell`` m whose free cells are ROBOT_RADIUS + cell / sqrt 2 clear."""
    xs = np.arange(lo[0] + cell / 2, hi[0], cell)
    ys = np.arange(lo[1] + cell / 2, hi[1], cell)
    gy, gx = np.meshgrid(ys, xs, indexing="ij")
    pts = np.stack([gx.ravel(), gy.ravel()], 1)
    free = ref.clearance(pts, walls, circles) >= maps.ROBOT_RADIUS + cell / math.sqrt(2)
    free = free.reshape(len(ys), len(xs))

    def cell_of(p):
        return (
            min(int((p[1] - lo[1]) / cell), len(ys) - 1),
            min(int((p[0] - lo[0]) / cell), len(xs) - 1),
        )

    s, g = cell_of(start), cell_of(goal)
    assert free[s] and free[g]  # 0.35 m clear: the cells around them are free
    seen = np.zeros_like(free)
    seen[s] = True
    queue = deque([s])
    while queue:
        r, c = queue.popleft()
        if (r, c) == g:
            return True
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r + dr, c + dc
                if 0 <= rr < free.shape[0] and 0 <= cc < free.shape[1]:
                    if free[rr, cc] and not seen[rr, cc]:
                        seen[rr, cc] = True
                        queue.append((rr, cc))
    return False


def draw_many(family, keys, split="train"):
    draw = cylinders.draw_cylinders if isinstance(family, cylinders.Cylinders) else rooms.draw_rooms
    return jax.tree.map(np.asarray, jax.jit(jax.vmap(lambda k: draw(k, family, split)))(keys))


def one(tree, i):
    return jax.tree.map(lambda x: x[i], tree)


@pytest.fixture(scope="module")
def cylinder_draws():
    return draw_many(CYL, KEYS)


@pytest.fixture(scope="module")
def rooms_draws():
    return draw_many(ROOMS, KEYS)


# ----------------------------------------------------------------------------
# Cylinders
# ----------------------------------------------------------------------------


def test_raster_distances_agree_with_numpy_dijkstra():
    codes = jax.vmap(lambda k: cylinders.cylinder_codes(k, CYL))(KEYS[:12])
    clear = np.asarray(jax.vmap(lambda c: cylinders.clearance_raster(CYL.circles(c), CYL))(codes))
    n = CYL.n_raster
    rng = np.random.default_rng(0)
    for free in clear >= cylinders.PASS_CLEARANCE:
        src = int(rng.choice(np.flatnonzero(free)))
        got = np.asarray(jax.jit(cylinders.raster_distances, static_argnums=2)(free, src, n))
        want = dijkstra(free, src, n)
        np.testing.assert_array_equal(np.isinf(got), np.isinf(want))
        ok = np.isfinite(want)
        np.testing.assert_allclose(got[ok], want[ok], rtol=1e-5)
        assert (~ok).sum() > 0  # the cylinders' cells at least are unreached


def test_a_wall_of_cylinders_with_one_gap_makes_the_path_go_round():
    # A raster with a blocked column but one free cell: the way round is exact.
    n = 9
    free = np.ones((n, n), bool)
    free[:, 4] = False
    free[7, 4] = True
    src, dst = 4 * n + 2, 4 * n + 6  # (row 4, col 2) to (row 4, col 6)
    d = np.asarray(cylinders.raster_distances(free.ravel(), src, n))
    assert d[dst] == pytest.approx(2 + 4 * math.sqrt(2))  # 3 diagonals up, 1 across, 3 down
    assert np.isinf(d[4 * n + 4])


def test_the_free_raster_agrees_with_brute_force_clearance():
    codes = jax.vmap(lambda k: cylinders.cylinder_codes(k, CYL))(KEYS[:8])
    centres = CYL.cell_centres().astype(np.float64)
    h = CYL.room / 2
    walls = np.array([[-h, -h, h, -h], [h, -h, h, h], [h, h, -h, h], [-h, h, -h, -h]])
    for c in codes:
        circles = np.asarray(CYL.circles(c), np.float64)
        got = np.asarray(cylinders.clearance_raster(CYL.circles(c), CYL))
        want = ref.clearance(centres, walls, circles)
        np.testing.assert_allclose(got, want, atol=1e-5)
        # Every cylinder inside the room, radii in range, centres on the lattice.
        assert (np.abs(circles[:, :2]) + circles[:, 2:] <= h + 1e-6).all()
        assert (circles[:, 2] >= 0.1 - 1e-6).all() and (circles[:, 2] <= 0.25 + 1e-6).all()
        on = (circles[:, :2] + h - 0.25) / draws.LATTICE
        np.testing.assert_allclose(on, np.round(on), atol=1e-3)


@pytest.mark.slow
def test_drawn_starts_and_goals_are_clear_and_joined_by_a_free_path(cylinder_draws):
    draws = cylinder_draws
    assert draws.ok.all()
    centres = CYL.cell_centres().astype(np.float64)
    n = CYL.n_raster
    h = CYL.room / 2
    walls = np.array([[-h, -h, h, -h], [h, -h, h, h], [h, h, -h, h], [-h, h, -h, -h]])
    for i in range(len(KEYS)):
        d = one(draws, i)
        circles = np.asarray(CYL.circles(d.codes), np.float64)
        start, goal = centres[d.start], centres[d.goal]
        clear = ref.clearance(np.stack([start, goal]), walls, circles)
        assert (clear >= maps.GOAL_CLEARANCE - 1e-5).all()
        # The free raster recomputed in float64, the path by Dijkstra on it.
        free = ref.clearance(centres, walls, circles) >= cylinders.PASS_CLEARANCE
        dist = dijkstra(free, int(d.start), n) * cylinders.RASTER
        assert dist[d.goal] == pytest.approx(float(d.path), rel=1e-4)
        assert dist[d.goal] >= CYL.min_path
        # The goal points: exactly the clear cells reachable from the start, not too near it.
        # (cells within float32 rounding of a threshold may go either way).
        clearances = ref.clearance(centres, walls, circles)
        from_start = np.linalg.norm(centres - start, axis=1)
        eligible = clearances >= maps.GOAL_CLEARANCE
        away = from_start >= maps.GOAL_START_CLEARANCE
        sharp = (np.abs(clearances - maps.GOAL_CLEARANCE) > 1e-5) & (
            np.abs(from_start - maps.GOAL_START_CLEARANCE) > 1e-5
        )
        want = eligible & np.isfinite(dist) & away
        np.testing.assert_array_equal(d.goals[sharp], want[sharp])
        # And a finer, independent raster agrees that the robot gets through.
        assert raster_reachable(walls, circles, (-h, -h), (h, h), start, goal)


def test_the_maze_of_a_draw_has_the_draws_cylinders_start_and_goal_points(cylinder_draws):
    d = one(cylinder_draws, 0)
    maze = jax.tree.map(np.asarray, cylinders.cylinders_maze(d, CYL, np.float32(0.5)))
    assert maze.segments.shape == (4, 4) and maze.circles.shape == (CYL.count, 3)
    assert maze.robotis_goals.shape == (256, 2)  # as every Maze
    np.testing.assert_allclose(maze.obstacles(), CYL.circles(d.codes))
    np.testing.assert_allclose(maze.start, [*CYL.cell_centres()[d.start], 0.5])
    n = int(maze.n_goal_points)
    assert n == d.goals.sum()
    want = CYL.cell_centres()[d.goals]
    np.testing.assert_array_equal(maze.goal_points[:n], want)
    assert {tuple(p) for p in maze.goal_points[n:]} <= {tuple(p) for p in want}
    np.testing.assert_allclose(maze.bounds, [-2, -2, 2, 2])


@pytest.mark.slow
def test_no_train_cylinder_field_equals_a_test_one():
    small = cylinders.Cylinders(1, 0.1, 0.12, 1.6, 0.3)  # 28^2 sites x 3 radii: draws repeat
    keys = jax.random.split(jax.random.PRNGKey(3), 3000)
    layouts = {}
    for split in ("train", "test"):
        d = draw_many(small, keys, split)
        assert d.ok.all()
        bits = np.asarray(jax.vmap(lambda c, s=small: cylinders.cylinder_split(c, s))(d.codes))
        assert (bits == ("train", "test").index(split)).all()
        layouts[split] = [tuple(sorted(map(tuple, c))) for c in d.codes]
    train, test = set(layouts["train"]), set(layouts["test"])
    assert len(train) < 3000 and len(test) < 3000  # layouts do repeat across draws
    assert len(train) > 500 and len(test) > 500
    assert not train & test


def test_a_cylinder_layouts_split_is_that_of_its_cylinders_in_any_order():
    codes = np.asarray(jax.vmap(lambda k: cylinders.cylinder_codes(k, CYL))(KEYS))
    rng = np.random.default_rng(1)
    bits = [int(cylinders.cylinder_split(c, CYL)) for c in codes]
    shuffled = [int(cylinders.cylinder_split(c[rng.permutation(len(c))], CYL)) for c in codes]
    assert bits == shuffled and 0 < sum(bits) < len(bits)


# ----------------------------------------------------------------------------
# Rooms
# ----------------------------------------------------------------------------


def room_graph_bfs(rooms: rooms.Rooms, open_: np.ndarray, src: int) -> np.ndarray:
    a, b = gen.wall_cells(rooms.grid)
    dist = np.full(rooms.grid.n_cells, -1)
    dist[src] = 0
    queue = deque([src])
    while queue:
        u = queue.popleft()
        for w in np.flatnonzero(open_):
            for p, q in ((a[w], b[w]), (b[w], a[w])):
                if p == u and dist[q] < 0:
                    dist[q] = dist[u] + 1
                    queue.append(q)
    return dist


@pytest.mark.slow
def test_rooms_doors_are_gaps_of_the_door_width_in_the_walls_with_a_door(rooms_draws):
    d = one(rooms_draws, 0)
    maze = jax.tree.map(np.asarray, rooms.rooms_maze(d, ROOMS, np.float32(0.0)))
    e = ROOMS.grid.n_walls
    assert maze.segments.shape == (ROOMS.n_segments, 4)
    first, second = maze.segments[:e], maze.segments[e : 2 * e]
    for w in range(e):
        if d.open[w]:
            assert maze.segment_mask[e + w]
            gap = np.linalg.norm(second[w, :2] - first[w, 2:])
            assert gap == pytest.approx(ROOMS.door, abs=1e-5)
            length = np.linalg.norm(first[w, 2:] - first[w, :2]) + np.linalg.norm(
                second[w, 2:] - second[w, :2]
            )
            assert length + gap == pytest.approx(ROOMS.size, abs=1e-5)
            assert min(np.linalg.norm(first[w, 2:] - first[w, :2]), gap) >= registry.DOOR_MARGIN
        else:
            assert not maze.segment_mask[e + w]
            assert np.linalg.norm(first[w, 2:] - first[w, :2]) == pytest.approx(ROOMS.size)


@pytest.mark.slow
def test_rooms_starts_and_goals_are_clear_in_rooms_apart_and_joined_by_a_free_path(rooms_draws):
    half = np.array([ROOMS.cols, ROOMS.rows]) * ROOMS.size / 2
    for i in range(len(KEYS)):
        d = one(rooms_draws, i)
        maze = jax.tree.map(np.asarray, rooms.rooms_maze(d, ROOMS, np.float32(0.0)))
        walls, circles = ref.maze_geometry(maze)
        clear = ref.clearance(np.stack([d.start, d.goal]).astype(np.float64), walls, circles)
        assert (clear >= maps.GOAL_CLEARANCE - 1e-5).all()
        assert d.start_room != d.goal_room
        rooms_apart = room_graph_bfs(ROOMS, d.open, int(d.start_room))[d.goal_room]
        assert rooms_apart == d.path_rooms >= ROOMS.min_path
        assert raster_reachable(walls, circles, -half, half, d.start, d.goal)


@pytest.mark.slow
def test_no_train_rooms_maze_equals_a_test_one():
    small = rooms.Rooms(2, 2, 1.0, 0.8)  # 4 spanning trees x 3^3 door positions: draws repeat
    keys = jax.random.split(jax.random.PRNGKey(4), 3000)
    layouts = {}
    for split in ("train", "test"):
        d = draw_many(small, keys, split)
        bits = np.asarray(jax.vmap(rooms.rooms_split)(d.open, d.offsets))
        assert d.ok.all() and (bits == ("train", "test").index(split)).all()
        layouts[split] = {np.where(o, f + 1, 0).tobytes() for o, f in zip(d.open, d.offsets)}
    assert 10 < len(layouts["train"]) < 3000 and 10 < len(layouts["test"]) < 3000
    assert not layouts["train"] & layouts["test"]


# ----------------------------------------------------------------------------
# An exhausted draw, settings
# ----------------------------------------------------------------------------


@pytest.mark.slow
def test_an_exhausted_draw_returns_the_valid_fallback_of_its_split(monkeypatch):
    monkeypatch.setattr(draws, "MAX_TRIES", 1)  # one candidate: half of them miss the split
    small = cylinders.Cylinders(2, 0.1, 0.15, 2.0, 0.5)
    d = draw_many(small, KEYS, "test")
    safe = draws.fallback(small, "test")
    fell_back = (d.codes == safe.codes).all(axis=(1, 2))
    assert d.ok.all() and 0 < fell_back.sum() < len(KEYS)
    bits = np.asarray(jax.vmap(lambda c: cylinders.cylinder_split(c, small))(d.codes))
    assert (bits == 1).all()
    draws.fallback.cache_clear()  # it was searched with one try per draw


def test_a_family_with_no_valid_maze_is_one_line_naming_its_settings():
    impossible = cylinders.Cylinders(1, 0.1, 0.1, 1.2, 3.0)  # 3 m of path in a 1.2 m room
    with pytest.raises(ConfigError, match="config: env.cyl_count, .* no valid train maze") as e:
        draws.fallback(impossible, "train")
    assert "\n" not in str(e.value)


def test_the_settings_constants_are_the_worlds():
    assert registry.ROBOT_DIAMETER == 2 * maps.ROBOT_RADIUS
    assert registry.GOAL_CLEARANCE == maps.GOAL_CLEARANCE
    assert registry.DOOR_MARGIN == registry.DOOR_MARGIN
    assert registry.CYLINDER_GROWTH == pytest.approx(cylinders.PASS_CLEARANCE, abs=0.01)
    assert "cylinders" in registry.names() and "rooms" in registry.names()


@pytest.mark.parametrize(
    "args, says",
    [
        ((0, (0.1, 0.2), 4.0, 1.0), "env.cyl_count"),
        ((65, (0.1, 0.2), 4.0, 1.0), "env.cyl_count"),
        ((30, (0.1, 0.25), 4.0, 1.0), "env.cyl_count: 30 cylinders"),
        ((8, (0.3, 0.1), 4.0, 1.0), "env.cyl_radius"),
        ((8, (0.0, 0.1), 4.0, 1.0), "env.cyl_radius"),
        ((1, (0.1, 1.8), 4.0, 1.0), "env.cyl_radius high"),
        ((8, (0.1, 0.2), -4.0, 1.0), "env.cyl_room"),
        ((8, (0.1, 0.2), 4.0, 1.7), "env.cyl_min_path"),
        ((8, (0.1, 0.2), 4.0, -0.5), "env.cyl_min_path"),
    ],
)
def test_bad_cylinder_settings_are_refused_naming_the_setting(args, says):
    assert registry.cylinders_problem(*args).startswith(says)
    assert registry.cylinders_problem(8, (0.1, 0.25), 4.0, 1.65) is None


@pytest.mark.parametrize(
    "args, says",
    [
        ((1, 1, 2.0, 0.6, 0.0, 1), "env.rooms_rows x env.rooms_cols"),
        ((0, 3, 2.0, 0.6, 0.0, 1), "env.rooms_rows"),
        ((2, -1, 2.0, 0.6, 0.0, 1), "env.rooms_cols"),
        ((2, 2, 2.0, 0.26, 0.0, 1), "env.rooms_door must be wider"),
        ((2, 2, 2.0, 1.95, 0.0, 1), "env.rooms_door must be at most"),
        ((2, 2, 0.6, 0.4, 0.0, 1), "env.rooms_size"),
        ((2, 2, 2.0, 0.6, 1.5, 1), "env.rooms_loops"),
        ((2, 2, 2.0, 0.6, 0.0, 3), "env.min_path_cells"),
    ],
)
def test_bad_rooms_settings_are_refused_naming_the_setting(args, says):
    assert registry.rooms_problem(*args).startswith(says)
    assert registry.rooms_problem(2, 3, 2.0, 0.6, 0.5, 3) is None
