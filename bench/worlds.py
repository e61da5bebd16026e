"""What the procedural and moving worlds cost.

Three measurements, each printed as a table (medians of several repetitions; every
case compiled once, compilation reported beside the steady state):

1. Environment steps/s at 4096 environments, random actions, 24 beams: a new 4x4,
   6x6 or 8x8 grid maze (or cylinder field, or rooms) every episode
   (``env.generator``), drawn when needed or picked from a bank (``env.maze_bank``),
   grids with each LiDAR broad phase (``env.broad_phase``), beside the same family's
   one maze held fixed (drawn once, passed as the maze), beside square4, stage 3 and
   stage 4 (moving cylinders). Cases alternate A B A B within one process so a noisy
   machine slows them alike; the ratio is the figure to read.
2. LiDAR cost against the number of wall segments: 24-beam scans of 4096 poses in
   closed grid mazes of 2x2 to 16x16 cells (12 to 544 segments), every wall tested
   beside the lattice walked (``jaxnav.world.lattice``), and square4's.
3. Training env steps/s of whole ``jaxnav train`` commands, square4 against drawn
   grids (drawn when needed, from a bank, each LiDAR broad phase): DQN at 64 runs (32
   seeds x 2 strategies) and PQN at 4 runs of 128 environments, the cases taking
   turns; each figure is the trainer's own steady-state rate, printed beside its
   compilation (no compilation cache) and the command's wall time.

    python bench/worlds.py            # about 15 minutes on 2 cores
    python bench/worlds.py --quick    # smoke run
    python bench/worlds.py --part lidar   # one part (env, lidar, train; repeatable)
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

BANK = 4096  # layouts in the bank of the "bank" cases (env.maze_bank)
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))


def env_cases(n_envs: int, n_steps: int, reps: int) -> list[dict]:
    import jax
    from env_throughput import rollout

    import jaxnav

    def fns(env, params):
        def reset(keys):
            return jax.vmap(env.reset, in_axes=(0, None))(keys, params)

        def step(keys, state, actions):
            obs, state, r, term, trunc, _ = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                keys, state, actions, params
            )
            return obs, state, r, term | trunc

        return reset, step

    cases, bank_s = {}, {}
    families = {
        "4x4 grid": {"generator": "grid", "grid_rows": 4, "grid_cols": 4, "min_path_cells": 2},
        "6x6 grid": {"generator": "grid", "grid_rows": 6, "grid_cols": 6, "min_path_cells": 2},
        "8x8 grid": {"generator": "grid", "grid_rows": 8, "grid_cols": 8, "min_path_cells": 2},
        "cylinder field": {"generator": "cylinders", "cyl_min_path": 1.5, "max_steps": 200},
        "2x2 rooms": {"generator": "rooms", "max_steps": 200},
    }
    for family, kwargs in families.items():
        env, params = jaxnav.make(**kwargs)
        cases[f"{family}, a new maze every episode"] = fns(env, params)
        banked = dataclasses.replace(env, maze_bank=BANK)
        t0 = time.perf_counter()
        with_bank = jax.block_until_ready(jax.jit(banked.with_bank)(params, jax.random.PRNGKey(0)))
        bank_s[family] = time.perf_counter() - t0
        cases[f"{family}, a new maze every episode, bank"] = fns(banked, with_bank)
        if kwargs["generator"] != "grid":  # its layout carried in the state, none drawn
            cases[f"{family}, bank, a layout kept 1000 episodes"] = fns(
                dataclasses.replace(banked, new_maze_every=1000), with_bank
            )
        if kwargs["generator"] == "grid":  # the LiDAR's other broad phase beside auto's
            other = "none" if banked.walks_lattice else "lattice"
            name = "every wall" if other == "none" else "lattice"
            cases[f"{family}, a new maze every episode, bank, {name}"] = fns(
                dataclasses.replace(banked, broad_phase=other), with_bank
            )
        fixed_maze = env.draw_maze(jax.random.PRNGKey(0))[0]
        keep = {k: v for k, v in kwargs.items() if k == "max_steps"}
        cases[f"{family}, one maze held fixed"] = fns(*jaxnav.make(fixed_maze, **keep))
    for maze in ("square4", "stage3", "stage4"):
        cases[maze] = fns(*jaxnav.make(maze))
    compiled = {}
    for name, (reset, step) in cases.items():
        run = jax.jit(rollout(reset, step, 5, n_envs, n_steps))
        t0 = time.perf_counter()
        jax.block_until_ready(run(jax.random.PRNGKey(0)))
        compiled[name] = (run, time.perf_counter() - t0)
    times = {name: [] for name in cases}
    for rep in range(reps):  # A B C ... A B C ...
        for name, (run, _) in compiled.items():
            t = time.perf_counter()
            jax.block_until_ready(run(jax.random.PRNGKey(1 + rep)))
            times[name].append(time.perf_counter() - t)
    return [
        {
            "case": name,
            "steps_per_s": n_envs * n_steps / statistics.median(ts),
            "first_call_s": compiled[name][1],
        }
        for name, ts in times.items()
    ], bank_s


def lidar_cases(n_poses: int, reps: int) -> list[dict]:
    """us per 24-beam scan of closed grids (every wall standing, 1 m cells) of 2x2 to
    16x16 cells, every wall tested beside the lattice walked, and of square4, the cases
    taking turns."""
    import jax
    import jax.numpy as jnp

    from jaxnav.world import generators as gen
    from jaxnav.world.maps import make_maze
    from jaxnav.world.sensor import beam_directions, beam_ranges

    cases = {}
    for size in (2, 4, 6, 8, 16):
        grid = gen.Grid(size, size, 1.0)
        closed = jnp.zeros(grid.n_walls, bool)  # every wall standing: the most segments
        maze = gen.layout_maze(closed, grid, jnp.int32(0), jnp.float32(0.0))
        key = jax.random.PRNGKey(size)
        pos = jax.random.uniform(key, (n_poses, 2), minval=-size / 2, maxval=size / 2)
        yaw = jax.random.uniform(jax.random.fold_in(key, 1), (n_poses,), minval=-3.0, maxval=3.0)
        segments = int(maze.segment_mask.sum())
        every = jax.vmap(lambda p, y, m=maze: beam_ranges(m, p, y, 24))
        walk = jax.vmap(lambda p, y, m=maze, g=grid: g.beam_ranges(m, p, beam_directions(24, y)))
        cases[(f"{size}x{size} grid", segments, "every wall")] = (jax.jit(every), pos, yaw)
        cases[(f"{size}x{size} grid", segments, "lattice")] = (jax.jit(walk), pos, yaw)
    square4 = make_maze("square4")
    key = jax.random.PRNGKey(4)
    pos = jax.random.uniform(key, (n_poses, 2), minval=-1.8, maxval=1.8)
    yaw = jax.random.uniform(jax.random.fold_in(key, 1), (n_poses,), minval=-3.0, maxval=3.0)
    scan = jax.jit(jax.vmap(lambda p, y: beam_ranges(square4, p, y, 24)))
    cases[("square4", int(square4.segment_mask.sum()), "every wall")] = (scan, pos, yaw)
    for fn, pos, yaw in cases.values():
        jax.block_until_ready(fn(pos, yaw))
    times = {k: [] for k in cases}
    for _ in range(reps):  # A B C ... A B C ..., each case 5 calls in a row (warm buffers)
        for k, (fn, pos, yaw) in cases.items():
            jax.block_until_ready(fn(pos, yaw))
            t = time.perf_counter()
            for _ in range(5):
                out = fn(pos, yaw)
            jax.block_until_ready(out)
            times[k].append((time.perf_counter() - t) / 5)
    return [
        {
            "maze": k[0],
            "segments": k[1],
            "caster": k[2],
            "us_per_scan": statistics.median(ts) / n_poses * 1e6,
        }
        for k, ts in times.items()
    ]


TRAINED = re.compile(r"trained (\d+) env steps in ([\d.]+) s \((\d+) steps/s\)")
COMPILED = re.compile(r"\(compilation ([\d.]+) s\)")
GRID6 = ["env.generator=grid", "env.grid_rows=6", "env.grid_cols=6", "env.min_path_cells=2"]
GRID4 = ["env.generator=grid", "env.grid_rows=4", "env.grid_cols=4", "env.min_path_cells=2"]


def train_groups(quick: bool) -> dict[str, dict[str, list[str]]]:
    """Whole ``jaxnav train`` commands, by group; each group's first case (square4) is
    the one the others are compared with."""
    seeds = 2 if quick else 32
    # The same env steps per run for every case (episodes end at different times), the
    # learner running from learning_starts on as in a real run.
    dqn_steps = 1000 if quick else 4000
    dqn = ["smoke", "env.max_steps=300", f"seeds={seeds}", "episodes=null"]
    dqn += [f"total_steps={dqn_steps}", f"run.chunk_steps={dqn_steps}"]
    pqn_steps = 16384 if quick else 409600
    pqn = ["pqn", "env.max_steps=200", "seeds=2", f"total_steps={pqn_steps}"]
    pqn += ["pqn.num_envs=128", f"run.chunk_steps={pqn_steps}", "run.test_mazes=[]"]
    return {
        f"DQN, {2 * seeds} runs (one environment each), {dqn_steps} env steps each": {
            "square4": dqn,
            "6x6 grids, drawn": [*dqn, *GRID6],
            "6x6 grids, bank": [*dqn, *GRID6, "env.maze_bank=64"],
            "6x6 grids, bank, every wall": [
                *dqn,
                *GRID6,
                "env.maze_bank=64",
                "env.broad_phase=none",
            ],
        },
        f"PQN, 4 runs of 128 environments, {pqn_steps} env steps each": {
            "square4": pqn,
            "4x4 grids, drawn": [*pqn, *GRID4],
            "4x4 grids, bank": [*pqn, *GRID4, "env.maze_bank=4096"],
            "6x6 grids, bank": [*pqn, *GRID6, "env.maze_bank=4096"],
        },
    }


def train_cases(cmds: dict[str, list[str]], reps: int) -> list[dict]:
    """Each command ``reps`` times, the cases taking turns, with no compilation cache
    (so each compiles: its compilation seconds are reported)."""
    rates = {k: [] for k in cmds}
    walls = {k: [] for k in cmds}
    compiles = {k: [] for k in cmds}
    env = {**os.environ, "JAXNAV_CACHE": "off"}
    for rep in range(reps):
        for name, args in cmds.items():
            out = f"/tmp/jaxnav-bench-worlds-{rep}"
            argv = [sys.executable, "-m", "jaxnav", "train", args[0], "--out", out, "--overwrite"]
            argv += [*args[1:], "run.test_mazes=[]"]
            t = time.perf_counter()
            proc = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT, env=env)
            walls[name].append(time.perf_counter() - t)
            m, c = TRAINED.search(proc.stdout), COMPILED.search(proc.stdout)
            if not (m and c):
                raise SystemExit(f"bench/worlds.py: {name} failed:\n{proc.stderr[-2000:]}")
            rates[name].append(int(m.group(3)))
            compiles[name].append(float(c.group(1)))
    return [
        {
            "case": k,
            "transitions_per_s": statistics.median(rates[k]),
            "compile_s": statistics.median(compiles[k]),
            "command_s": statistics.median(walls[k]),
        }
        for k in cmds
    ]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument(
        "--part", choices=("env", "lidar", "train"), action="append", help="only these parts"
    )
    p.add_argument("--agent", choices=("dqn", "pqn"), help="the training part for one agent")
    a = p.parse_args(argv)
    parts = a.part or ("env", "lidar", "train")
    if "env" in parts:
        env_part(a.quick)
    if "lidar" in parts:
        lidar_part(a.quick)
    if "train" in parts:
        train_part(a.quick, a.agent)
    return 0


def env_part(quick: bool) -> None:
    n_envs, n_steps, reps = (256, 20, 2) if quick else (4096, 20, 3)
    rows, bank_s = env_cases(n_envs, n_steps, reps)
    base = {r["case"]: r["steps_per_s"] for r in rows}
    print(f"\nenvironment steps/s, {n_envs} envs, random actions, median of {reps}")
    print(f"  {'case':<52} {'steps/s':>10} {'first call s':>13}")
    for r in rows:
        print(f"  {r['case']:<52} {r['steps_per_s']:>10.0f} {r['first_call_s']:>13.1f}")
    for family, seconds in bank_s.items():
        new = base[f"{family}, a new maze every episode"]
        banked = base[f"{family}, a new maze every episode, bank"]
        fixed = base[f"{family}, one maze held fixed"]
        print(
            f"  {family}: a new maze every episode keeps {new / fixed:.0%} of the fixed maze's, "
            f"{banked / fixed:.0%} from a bank of {BANK} (drawn in {seconds:.1f} s, "
            "compilation included)"
        )
        for name in ("lattice", "every wall"):
            other = base.get(f"{family}, a new maze every episode, bank, {name}")
            if other:
                print(f"    from the bank with the LiDAR's {name}: {other / fixed:.0%}")
        kept = base.get(f"{family}, bank, a layout kept 1000 episodes")
        if kept:
            print(f"    a layout kept 1000 episodes (none drawn or picked): {kept / fixed:.0%}")


def lidar_part(quick: bool) -> None:
    n_poses, reps = (512, 3) if quick else (4096, 7)
    rows = lidar_cases(n_poses, reps)
    print(f"\nLiDAR, 24 beams, {n_poses} poses, closed grids of 1 m cells, median of {reps}")
    print(f"  {'maze':<12} {'segments':>8} {'caster':<11} {'us/scan':>8} {'x square4':>10}")
    square4 = next(r["us_per_scan"] for r in rows if r["maze"] == "square4")
    for r in rows:
        print(
            f"  {r['maze']:<12} {r['segments']:>8} {r['caster']:<11} {r['us_per_scan']:>8.2f} "
            f"{r['us_per_scan'] / square4:>10.1f}"
        )


def train_part(quick: bool, agent: str | None = None) -> None:
    reps = 1 if quick else 2
    for group, cmds in train_groups(quick).items():
        if agent and not group.startswith(agent.upper()):
            continue
        rows = train_cases(cmds, reps)
        print(f"\ntraining: {group}, median of {reps} whole commands")
        head = f"{'steps/s':>9} {'x square4':>10} {'compile s':>10} {'x':>5} {'command s':>10}"
        print(f"  {'case':<30} {head}")
        base = rows[0]
        for r in rows:
            print(
                f"  {r['case']:<30} {r['transitions_per_s']:>9.0f} "
                f"{r['transitions_per_s'] / base['transitions_per_s']:>10.0%} "
                f"{r['compile_s']:>10.1f} {r['compile_s'] / base['compile_s']:>5.2f} "
                f"{r['command_s']:>10.1f}"
            )


if __name__ == "__main__":
    raise SystemExit(main())
