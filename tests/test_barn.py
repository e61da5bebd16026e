"""BARN: the shipped worlds honour the facts of the challenge's files, the converter
reads a world file as it should and refuses one that breaks a fact, the protocol's
numbers and splits are the challenge's, and BARN's metrics recomputed from its own
published DWA runs are those of its report_test.py."""

from __future__ import annotations

from pathlib import Path

import _nav_reference as ref
import numpy as np
import pytest

from jaxnav.core import worlds
from jaxnav.core.config import load_config
from jaxnav.report import barn as rb
from jaxnav.world import barn, barn_convert
from jaxnav.world.maps import make_maze
from jaxnav.world.sensor import lidar_scan

ROOT = Path(__file__).resolve().parents[1]


def test_every_world_is_a_field_of_cylinders_between_full_side_walls_above_the_corridor():
    d = barn.data()
    cyl, occ = d["cylinders"], d["occupied"]
    assert cyl.shape == occ.shape == (300, 64, 30)
    field = cyl[:, barn_convert.FIELD_ROW :]  # 30 rows of y above 5.1 m
    assert field.shape[1] == 30
    assert field[:, :, 0].all() and field[:, :, 29].all()  # BARN's grid rows 0 and 29
    corridor = barn_convert.corridor()[: barn_convert.FIELD_ROW]
    assert (cyl[:, : barn_convert.FIELD_ROW] == corridor).all()
    assert (occ >= cyl).all()  # the filled cells are added, none taken away


def test_the_filled_cells_are_sealed_off_by_touching_cylinders():
    d = barn.data()
    added = d["occupied"] & ~d["cylinders"]
    assert added.sum() > 0
    for n in np.unique(np.nonzero(added)[0])[:40]:
        occ, cyl = d["occupied"][n], d["cylinders"][n]
        # every filled cell's 4 orthogonal neighbours are occupied (a cylinder or filled
        # too): nothing free touches it along a side, so no gap between cylinders opens
        rows, cols = np.nonzero(occ & ~cyl)
        for i, j in zip(rows, cols):
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                assert occ[i + di, j + dj], (n, i, j)
        # and through diagonal gaps neither: every 8-neighbour is occupied
        for i, j in zip(rows, cols):
            assert occ[i - 1 : i + 2, j - 1 : j + 2].all()


def test_sealed_filling_by_hand():
    cyl = np.zeros((64, 30), bool)
    cyl[40:43, 10:13] = True
    cyl[41, 11] = False  # a free cell inside a ring of eight: sealed
    cyl[50:53, 10:13] = True
    cyl[51, 11] = cyl[50, 10] = False  # a free cell opening diagonally: not sealed
    occ = barn_convert.sealed_filled(cyl)
    assert occ[41, 11] and not occ[51, 11]


def _world_text(cylinders, radius="0.075000", lifted=0.0):
    models = "".join(
        f"<model name='unit_cylinder_{k}'>\n<static>1</static>\n"
        f"<pose frame=''>{x:.6f} {y:.6f} {lifted:.6f} 0 0 0</pose>\n"
        f"<link name='link'><collision name='collision'><geometry><cylinder><radius>{radius}"
        "</radius><length>1</length></cylinder></geometry></collision></link></model>\n"
        for k, (x, y) in enumerate(cylinders)
    )
    return f"<sdf version='1.6'><world name='default'>{models}<state world_name='default'>" + (
        "<model name='unit_cylinder_0'><pose frame=''>9 9 9 0 0 0</pose></model></state>"
    )


def test_a_world_file_is_read_from_its_models_first_poses():
    grid = barn_convert.cylinders_of(_world_text([(-4.425, 0.075), (-2.25 + 0.075, 5.175)]), "w")
    assert grid.sum() == 2 and grid[0, 0] and grid[34, 15]  # the state block's pose is not read
    with pytest.raises(barn_convert.BarnFormatError, match="radius"):
        barn_convert.cylinders_of(_world_text([(-4.425, 0.075)], radius="0.1"), "w")
    with pytest.raises(barn_convert.BarnFormatError, match="lattice"):
        barn_convert.cylinders_of(_world_text([(-4.4, 0.075)]), "w")
    with pytest.raises(barn_convert.BarnFormatError, match="lifted"):
        barn_convert.cylinders_of(_world_text([(-4.425, 0.075)], lifted=0.5), "w")


def test_the_reference_paths_are_measured_as_run_py_measures_them():
    d = barn.data()
    lengths = d["path_length"]
    assert lengths.min() == pytest.approx(10.05, abs=0.005)
    assert lengths.max() == pytest.approx(13.74, abs=0.005)
    assert lengths.mean() == pytest.approx(11.42, abs=0.005)
    # by hand: a path of one cell (15, 0) at (-2.325, 5.075), from (-2.25, 3) to (-2.25, 13)
    one = np.array([[15, 0]])
    want = np.hypot(0.075, 2.075) + np.hypot(0.075, 7.925)
    assert barn_convert.path_length(one, barn_convert.START) == pytest.approx(want)


def test_the_protocol_and_the_splits_are_the_challenges():
    maze = make_maze("barn:0")
    np.testing.assert_allclose(np.asarray(maze.start), [-2.25, 3.0, np.pi / 2], atol=1e-6)
    np.testing.assert_allclose(np.asarray(maze.goal), [-2.25, 13.0])
    assert barn.GOAL_RADIUS == 1.0 and barn.TIME_LIMIT == 100.0
    assert barn.TEST == tuple(range(0, 300, 6)) and len(barn.TEST) == 50
    assert len(barn.TRAIN) == 250 and not set(barn.TEST) & set(barn.TRAIN)
    assert worlds.expand(["barn:test"]) == [f"barn:{n}" for n in range(0, 300, 6)]
    cfg = load_config("barn")
    assert cfg.env.robot == "jackal" and cfg.env.goal_ends and cfg.env.goal_radius == 1.0
    assert cfg.env.max_steps * 0.2 == pytest.approx(barn.TIME_LIMIT)


@pytest.mark.slow  # 6 s on 2 cores
def test_a_barn_worlds_scan_equals_a_brute_force_caster_of_its_cylinders():
    maze = make_maze("barn:150")
    walls, circles = ref.maze_geometry(maze)
    assert len(walls) == 0 and len(circles) == int(np.asarray(maze.grid.occupied).sum())
    rng = np.random.default_rng(0)
    pts = rng.uniform([-4.4, 0.2], [-0.1, 9.5], (400, 2))
    pts = pts[ref.clearance(pts, walls, circles) > 0.01][:60]
    yaw = rng.uniform(-np.pi, np.pi, len(pts))
    for p, y in zip(pts, yaw):
        got = np.asarray(lidar_scan(maze, p.astype(np.float32), np.float32(y), 72, 0.1, 10.0))
        angles = (y + np.arange(72) * 2 * np.pi / 72)[None]
        want = np.clip(ref.ray_distances(p[None], angles, walls, circles)[0], 0.1, 10.0)
        np.testing.assert_allclose(got, want, atol=1e-4)


def test_barns_published_dwa_runs_give_report_test_pys_figures():
    runs = rb.dwa_out_runs((ROOT / "docs" / "barn" / "dwa_out.txt").read_text())
    assert len(runs) == 500 and len({r["world"] for r in runs}) == 50
    m = rb.seed_metrics(runs)
    assert m["success"] == pytest.approx(0.85) and m["collision"] == pytest.approx(0.056)
    assert m["timeout"] == pytest.approx(0.094) and m["time_s"] == pytest.approx(34.0925, abs=1e-4)
    assert m["score_2022"] == pytest.approx(0.1580, abs=5e-5)  # start (-2, 3), clip 4-8 OT
    assert m["score"] == pytest.approx(0.1586, abs=5e-5)  # start (-2.25, 3), clip 2-8 OT


def test_the_score_by_hand():
    # OT 5 s: 8 s clips to 10 (2 OT) -> 0.5; 30 s -> 5/30; 60 s clips to 40 (8 OT); a failure 0
    got = rb.score([1, 1, 1, 0], [8.0, 30.0, 60.0, 8.0], 5.0)
    np.testing.assert_allclose(got, [0.5, 5 / 30, 5 / 40, 0.0])
    np.testing.assert_allclose(rb.score([1], [8.0], 5.0, rb.CLIPS["score_2022"]), [0.25])


def test_unknown_barn_names_are_refused_in_one_line():
    with pytest.raises(Exception, match="unknown maze 'barn:300'"):
        make_maze("barn:300")


def test_the_page_sets_the_published_rows_beside_jaxnavs():
    from jaxnav.report.barn_page import table

    lines = table(ROOT)
    readme = next(ln for ln in lines if ln.startswith("| DWA, the challenge's README"))
    assert "0.880" in readme and "0.1693" in readme
    recomputed = next(ln for ln in lines if "dwa_out.txt" in ln)
    assert "0.850" in recomputed and "0.056" in recomputed and "0.1580" in recomputed
    assert any(ln.startswith("| DRL-VO") and "0.2339" in ln for ln in lines)


def test_the_burgers_rows_average_as_report_test_py_does_by_hand():
    """The burger's policy row: per seed, each world's 10 runs averaged, then the 50
    worlds; then the mean over seeds (pandas-free NumPy over the committed CSV)."""
    import csv

    from jaxnav.report.barn_page import burger_rows, burger_sentence, burger_table

    path = ROOT / "docs" / "barn" / "burger" / "anywhere" / "results.csv"
    rows = [r for r in csv.DictReader(path.open()) if r["maze"].startswith("barn:")]
    seeds = sorted({int(r["seed"]) for r in rows})
    per_seed = []
    for s in seeds:
        worlds = {}
        for r in rows:
            if int(r["seed"]) == s:
                worlds.setdefault(r["maze"], []).append(float(r["successes"]) > 0)
        assert len(worlds) == 50 and all(len(v) == 10 for v in worlds.values())
        per_seed.append(np.mean([np.mean(v) for v in worlds.values()]))
    want = f"{np.mean(per_seed):.3f}"
    row = next(ln for ln in burger_table(burger_rows(ROOT)) if "drive_anywhere" in ln)
    assert row.split(" | ")[3].startswith(want) and "16 x 50 x 10" in row
    assert f"reaches a success of {np.mean(per_seed):.2f} [" in burger_sentence(burger_rows(ROOT))
    # the README's line on BARN quotes the same figures
    from jaxnav.report.barn_page import readme_line

    assert f"reaches {np.mean(per_seed):.2f} (the oracle 1.00, DWA 0.65)" in readme_line(ROOT)
    assert "the oracle 1.00 and DWA 0.65" in burger_sentence(burger_rows(ROOT))


def test_dwa_with_barns_parameters_samples_its_velocities_and_commands_them_exactly():
    import dataclasses

    import jax.numpy as jnp

    import jaxnav
    from jaxnav.planners import dwa

    vx = sorted({v for v, _ in dwa.BARN_VELOCITIES if v > 0})
    np.testing.assert_allclose(vx, np.linspace(0.1, 0.5, 6))
    turns = sorted({w for v, w in dwa.BARN_VELOCITIES if v > 0})
    np.testing.assert_allclose(turns, np.linspace(-1.57, 1.57, 20))
    env, params = jaxnav.make("square4", robot="jackal", reward="progress", **dwa.BARN_SETTINGS)
    for v, w in dwa.BARN_VELOCITIES[::7]:
        got = env.command(params, dwa.continuous_action(env, v, w))
        np.testing.assert_allclose([float(got[0]), float(got[1])], [v, w], atol=1e-5)
    planner = dwa.barn_dwa(dataclasses.replace(env), 0.25)
    v = jnp.asarray([0.0, 0.0, 0.3]), jnp.asarray([0.785, -0.785, -0.5])
    turned = planner._remember_turn((jnp.float32(0), jnp.zeros(2)), jnp.zeros(2), v[0][0], v[1][0])
    allowed, _ = planner._no_reversal(turned, jnp.asarray([0.01, 0.0]), *v)
    assert list(np.asarray(allowed)) == [True, False, True]  # no turning back in place
    allowed, _ = planner._no_reversal(turned, jnp.asarray([0.06, 0.0]), *v)
    assert np.asarray(allowed).all()  # once it has moved 0.05 m


def test_a_config_testing_on_barns_test_set_starts():
    """run.test_mazes naming a set of worlds (barn:test) is checked world by world before
    training starts, as the test reads it; a misspelt set is refused in one line."""
    from jaxnav.core.config import load_config
    from jaxnav.core.errors import ConfigError
    from jaxnav.run.launch import check_test_mazes

    check_test_mazes(load_config("drive_barn", []))
    with pytest.raises(ConfigError, match="unknown maze 'barn:tset'"):
        check_test_mazes(load_config("drive_barn", ["run.test_mazes=[barn:tset]"]))


def _policy_per_seed(folder: str) -> tuple[np.ndarray, np.ndarray]:
    """Per seed of a drive_barn row's committed CSV: success and collision, each world's
    10 runs averaged, then the 50 worlds (NumPy, beside the page's own reading)."""
    import csv

    path = ROOT / "docs" / "barn" / folder / "results.csv"
    rows = [
        r
        for r in csv.DictReader(path.open())
        if r["maze"].startswith("barn:") and r["mode"] == "greedy"
    ]
    success, collided = {}, {}
    for r in rows:
        key = (int(r["seed"]), r["maze"])
        success.setdefault(key, []).append(float(r["successes"]) > 0)
        collided.setdefault(key, []).append(float(r["collisions"]) > 0)
    seeds = sorted({s for s, _ in success})
    assert len(seeds) == 16 and len(success) == 16 * 50

    def per_seed(runs):
        return np.asarray(
            [np.mean([np.mean(v) for (s, _), v in runs.items() if s == n]) for n in seeds]
        )

    return per_seed(success), per_seed(collided)


def test_the_readme_and_the_page_quote_drive_barns_committed_rows():
    """drive_barn's success and collisions as the README's line and the page's note give
    them, at its budget and at half of it: the mean over seeds, and the seeds' range."""
    import json

    from jaxnav.report.barn_page import readme_line

    ok, hit = _policy_per_seed("policy")
    assert (
        f"(`drive_barn`, 16 seeds) reaches {ok.mean():.2f}, with collisions {hit.mean():.2f};"
        in (readme_line(ROOT))
    )
    notes = " ".join(
        " ".join(json.loads((ROOT / "docs" / "barn" / "made.json").read_text())["notes"]).split()
    )
    assert f"Its seeds range from {ok.min():.2f} to {ok.max():.2f}" in notes
    half, half_hit = _policy_per_seed("policy_half")
    said = f"at half its budget it reached {half.mean():.2f} with collisions {half_hit.mean():.2f}"
    assert said in notes
