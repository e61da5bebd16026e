"""What occupancy-grid worlds cost: environment steps/s at 4096 environments, random
actions, 24 beams (the paper's settings), on a 200 x 200-cell map beside square4.

The map is a building as SLAM draws one, made here so the figure needs no file: 10 m x
10 m at 0.05 m per cell, four rooms behind 0.1 m walls with doors, furniture, and a
ring of unknown (occupied) cells around. Cases:

* square4 (4 wall segments: the cheapest world);
* the 200 x 200 map, its grid walked for the LiDAR and windowed for collision
  (:mod:`jaxnav.world.occupancy`), with the burger's 3.5 m LiDAR;
* the same map with a 2 m LiDAR (the walk's cost grows with the range in cells);
* a BARN world (:mod:`jaxnav.world.barn`, discs of 0.075 m on 0.15 m cells, 30 x 64
  cells), the paper's settings otherwise.

Cases take turns (A B C A B C) so a noisy machine slows them alike; medians of the
repetitions; compilation excluded and reported. The ratio to square4 is the figure to
read (the target: at least 50% on the 200 x 200 map).

    python bench/grid_worlds.py            # about 3 minutes on 2 cores
    python bench/grid_worlds.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))


def building(cells: int = 200, res: float = 0.05):
    """bool[cells, cells]: four rooms with doors and furniture inside a ring of walls."""
    import numpy as np

    occ = np.zeros((cells, cells), bool)
    occ[:6], occ[-6:], occ[:, :6], occ[:, -6:] = True, True, True, True  # unknown beyond
    mid = cells // 2
    occ[mid - 1 : mid + 1], occ[:, mid - 1 : mid + 1] = True, True  # inner walls, 0.1 m
    for a, b in ((mid - 1, 30), (mid - 1, 140), (40, mid - 1), (150, mid - 1)):
        if a == mid - 1:
            occ[a : a + 2, b : b + 18] = False  # a 0.9 m door
        else:
            occ[a : a + 18, b : b + 2] = False
    rng = np.random.default_rng(0)
    for _ in range(24):  # tables, shelves, bins
        i, j = rng.integers(12, cells - 30, 2)
        h, w = rng.integers(4, 20, 2)
        occ[i : i + h, j : j + w] = True
    occ[90:110, 10:30] = False  # room around the start
    return occ


def cases():
    import jax
    import numpy as np

    import jaxnav
    from jaxnav.world.gridmaze import grid_maze
    from jaxnav.world.occupancy import make_occupancy

    res = 0.05
    grid = make_occupancy(building(), (-5.0, -5.0), res)
    start = np.array([-5.0 + 20 * res, -5.0 + 100 * res, 0.0])
    flat = grid_maze(grid, start, "the bench's building")
    out = {
        "square4": jaxnav.make("square4"),
        "200 x 200 cells, 3.5 m LiDAR": jaxnav.make(flat),
        "200 x 200 cells, 2 m LiDAR": jaxnav.make(flat, max_range=2.0),
    }
    try:
        out["BARN world 0 (discs), 3.5 m LiDAR"] = jaxnav.make("barn:0")
    except Exception as e:  # BARN's data not shipped in this tree
        print(f"(no BARN case: {e})")
    del jax
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    args = p.parse_args(argv)
    import jax
    from env_throughput import rollout

    n_envs, n_steps, reps = (256, 10, 2) if args.quick else (4096, 20, 5)

    def fns(env, params):
        def reset(keys):
            return jax.vmap(env.reset, in_axes=(0, None))(keys, params)

        def step(keys, state, actions):
            obs, state, r, term, trunc, _ = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                keys, state, actions, params
            )
            return obs, state, r, term | trunc

        return reset, step

    compiled = {}
    for name, (env, params) in cases().items():
        run = jax.jit(rollout(*fns(env, params), env.num_actions, n_envs, n_steps))
        t0 = time.perf_counter()
        jax.block_until_ready(run(jax.random.PRNGKey(0)))
        compiled[name] = (run, time.perf_counter() - t0)
    times = {name: [] for name in compiled}
    for rep in range(reps):
        for name, (run, _) in compiled.items():
            t = time.perf_counter()
            jax.block_until_ready(run(jax.random.PRNGKey(1 + rep)))
            times[name].append(time.perf_counter() - t)
    base = n_envs * n_steps / statistics.median(times["square4"])
    print(f"environment steps/s, {n_envs} envs, {n_steps} steps, random actions, median of {reps}")
    print(f"  {'case':<38} {'steps/s':>10} {'of square4':>11} {'first call s':>13}")
    for name, ts in times.items():
        rate = n_envs * n_steps / statistics.median(ts)
        print(f"  {name:<38} {rate:>10.0f} {rate / base:>11.0%} {compiled[name][1]:>13.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
