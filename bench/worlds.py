"""What the procedural and moving worlds cost.

Three measurements, each printed as a table (medians of several repetitions; every
case compiled once, compilation reported beside the steady state):

1. Environment steps/s at 4096 environments, random actions, 24 beams: a new 4x4 or
   6x6 grid maze every episode (``env.generator: grid``) beside the same family's
   one maze held fixed (drawn once, passed as the maze), beside square4, stage 3 and
   stage 4 (moving cylinders). Cases alternate A B A B within one process so a noisy
   machine slows them alike; the ratio is the figure to read.
2. LiDAR cost against the number of wall segments: 24-beam scans of 4096 poses in
   closed grid mazes of 2x2 to 8x8 cells (12 to 144 segments).
3. Training transitions/s of the whole ``jaxnav train`` command at 64 runs (32 seeds
   x 2 strategies), square4 against 6x6 grids drawn every episode, in the same
   alternating order; each figure is the trainer's own steady-state rate, printed
   beside the command's wall time.

    python bench/worlds.py            # about 15 minutes on 2 cores
    python bench/worlds.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import dataclasses
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
    import jax
    import jax.numpy as jnp

    from jaxnav.world import generators as gen
    from jaxnav.world.sensor import beam_ranges

    out = []
    for size in (2, 4, 6, 8):
        grid = gen.Grid(size, size, 0.6)
        closed = jnp.zeros(grid.n_walls, bool)  # every wall standing: the most segments
        maze = gen.layout_maze(closed, grid, jnp.int32(0), jnp.float32(0.0))
        half = size * 0.3
        key = jax.random.PRNGKey(size)
        pos = jax.random.uniform(key, (n_poses, 2), minval=-half, maxval=half)
        yaw = jax.random.uniform(jax.random.fold_in(key, 1), (n_poses,), minval=-3.0, maxval=3.0)
        scan = jax.jit(jax.vmap(lambda p, y, m=maze: beam_ranges(m, p, y, 24)))
        jax.block_until_ready(scan(pos, yaw))
        ts = []
        for _ in range(reps):
            t = time.perf_counter()
            jax.block_until_ready(scan(pos, yaw))
            ts.append(time.perf_counter() - t)
        out.append(
            {
                "segments": int(maze.segment_mask.sum()),
                "us_per_scan": statistics.median(ts) / n_poses * 1e6,
            }
        )
    return out


TRAINED = re.compile(r"trained (\d+) env steps in ([\d.]+) s \((\d+) steps/s\)")


def train_cases(seeds: int, episodes: int, reps: int) -> list[dict]:
    cmds = {
        "square4": ["smoke", "env.max_steps=300"],
        "6x6 grids, new every episode": [
            "grid4",
            "env.grid_rows=6",
            "env.grid_cols=6",
            "env.max_steps=300",
        ],
        "6x6 grids, new every episode, bank": [
            "grid4",
            "env.grid_rows=6",
            "env.grid_cols=6",
            "env.max_steps=300",
            "env.maze_bank=8",  # a run plays 5 episodes: a bank of their size
        ],
    }
    rates = {k: [] for k in cmds}
    walls = {k: [] for k in cmds}
    for rep in range(reps):
        for name, args in cmds.items():
            out = f"/tmp/jaxnav-bench-worlds-{rep}"
            argv = [sys.executable, "-m", "jaxnav", "train", args[0], "--out", out, "--overwrite"]
            argv += [*args[1:], f"seeds={seeds}", f"episodes={episodes}", "run.test_mazes=[]"]
            t = time.perf_counter()
            proc = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT)
            walls[name].append(time.perf_counter() - t)
            m = TRAINED.search(proc.stdout + proc.stderr)
            if not m:
                raise SystemExit(f"bench/worlds.py: {name} failed:\n{proc.stderr[-2000:]}")
            rates[name].append(int(m.group(3)))
    return [
        {
            "case": k,
            "transitions_per_s": statistics.median(rates[k]),
            "command_s": statistics.median(walls[k]),
        }
        for k in cmds
    ]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    a = p.parse_args(argv)
    n_envs, n_steps, reps = (256, 20, 2) if a.quick else (4096, 20, 3)
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
    print(f"\nLiDAR, 24 beams, {512 if a.quick else 4096} poses, closed grids")
    print(f"  {'segments':>8} {'us/scan':>8}")
    for r in lidar_cases(512 if a.quick else 4096, reps):
        print(f"  {r['segments']:>8} {r['us_per_scan']:>8.2f}")
    seeds, episodes, treps = (2, 5, 1) if a.quick else (32, 5, 2)
    rows = train_cases(seeds, episodes, treps)
    print(
        f"\ntraining, {2 * seeds} runs, {episodes} episodes of up to 300 steps, median of {treps}"
    )
    print(f"  {'case':<32} {'transitions/s':>14} {'command s':>10}")
    for r in rows:
        print(f"  {r['case']:<32} {r['transitions_per_s']:>14.0f} {r['command_s']:>10.1f}")
    for r in rows[1:]:
        ratio = r["transitions_per_s"] / rows[0]["transitions_per_s"]
        print(f"  {r['case']} keep {ratio:.0%} of square4's transitions/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
