"""JAX peer: rejax's DQN (PyPI ``rejax``) trained on jaxnav, against our trainer.

rejax (0.1.3) is a library of end-to-end jitted agents over gymnax environments,
vmappable over seeds like ours. Its DQN runs on our environment unchanged through a
thin adapter (:class:`GymnaxNav`): rejax 0.1.3 unpacks the pre-1.0 gymnax ``step``
(5 values, one ``done``), while gymnax 1.0 and jaxnav return 6 (``terminated`` and
``truncated``), so the adapter hands it ``done = terminated | truncated`` and gymnax
``spaces``. Everything else is rejax's own code.

Settings, made to match ours (paper Table 2) where rejax allows:

* network 64-64 ReLU, 5 linear outputs (rejax's ``QNetwork``; no dropout; flax's
  default lecun-normal init instead of lecun-uniform);
* RMSprop(lr 2.5e-4, rho 0.9, eps 1e-6 outside the sqrt): rejax hard-codes Adam, so
  :class:`DQNRMSprop` overrides the one method that builds the optimiser;
* gamma 0.9, batch 64, one gradient step per env step (``num_envs=1``,
  ``num_epochs=1``), hard target copy every 2000 steps (``polyak=0``), plain DQN
  targets (``ddqn=False``), learning after 64 transitions (``fill_buffer=64``), the
  same replay capacity as ours;
* exploration: rejax only has a linear epsilon schedule (1.0 -> 0.05 over a fraction
  of the run); ours is EBE, whose forward pass runs every step either way.

Differences that cost time and that we left as rejax has them: its buffer stores
``next_obs`` as well as ``obs``; it samples with ``jax.random.choice(replace=False,
p=...)`` over the whole capacity (a Gumbel top-k: O(capacity) work per gradient
step, where ours draws 64 indices); it treats truncation as terminal.

Timing: the state is initialised, one call of ``steps`` train iterations compiles and
warms up, then ``reps`` further calls are timed (median). rejax's periodic evaluation
is switched off (``skip_initial_evaluation`` and a no-op ``eval_callback``). Our
trainer is measured by bench/train_throughput.py in its own process with the same
seeds, beams, steps, reps and capacity. Both run on one CPU device per core with
the seeds split over the devices (rejax's vmapped seed axis is sharded by placing
its keys; the compiler partitions the rest).

    python bench/peers_rejax.py                 # 1 and 32 seeds, 24 beams
    python bench/peers_rejax.py --quick
    python bench/peers_rejax.py --seeds 1 8 32 --beams 24 360 --json out.json

rejax runs in this interpreter if it has it, else in ``.venv-peers`` (bench/README.md).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from common import MARK, cores, device_env, find_python, machine, ours_train, run_marked

PEER = "rejax DQN 0.1.3"


def gymnax_env(env, params):
    """jaxnav's ``env`` through the pre-1.0 gymnax API that rejax 0.1.3 unpacks."""
    import jax.numpy as jnp
    import numpy as np
    from gymnax.environments import spaces

    class GymnaxNav:
        def __init__(self, env, params):
            self.env, self.params = env, params
            # Built eagerly: NavEnv.observation_space does jnp arithmetic on the maze
            # bounds, which turns into tracers when rejax calls it under jit.
            box = env.observation_space(params)
            self._obs_space = spaces.Box(
                np.asarray(box.low), np.asarray(box.high), box.shape, jnp.float32
            )

        @property
        def default_params(self):
            return self.params

        def reset(self, key, params):
            return self.env.reset(key, params)

        def step(self, key, state, action, params):
            obs, state, reward, terminated, truncated, info = self.env.step(
                key, state, action, params
            )
            return obs, state, reward, terminated | truncated, info

        def action_space(self, params=None):
            return spaces.Discrete(self.env.num_actions)

        def observation_space(self, params=None):
            return self._obs_space

    return GymnaxNav(env, params)


def dqn_rmsprop():
    """rejax's DQN class with the paper's RMSprop in place of its hard-coded Adam."""
    import jax.numpy as jnp
    import optax
    from flax.training.train_state import TrainState
    from rejax import DQN
    from rejax.algos.algorithm import register_init

    class DQNRMSprop(DQN):
        @register_init
        def initialize_network_params(self, rng):
            obs_ph = jnp.empty([1, *self.env.observation_space(self.env_params).shape])
            q_params = self.agent.init(rng, obs_ph)
            tx = optax.rmsprop(self.learning_rate, decay=0.9, eps=1e-6, eps_in_sqrt=False)
            q_ts = TrainState.create(apply_fn=(), params=q_params, tx=tx)
            return {"q_ts": q_ts, "q_target_params": q_params}

    return DQNRMSprop


def make_rejax(beams: int, steps: int, capacity: int, maze: str = "square4"):
    """The rejax DQN algorithm on jaxnav with our hyperparameters."""
    import jax.numpy as jnp

    import jaxnav

    env, params = jaxnav.make(maze, n_beams=beams)
    algo = dqn_rmsprop().create(
        env=gymnax_env(env, params),
        env_params=params,
        agent_kwargs={"activation": "relu"},
        total_timesteps=steps,
        eval_freq=steps,
        skip_initial_evaluation=True,
        num_envs=1,
        num_epochs=1,
        learning_rate=2.5e-4,
        gamma=0.9,
        batch_size=64,
        buffer_size=capacity,
        fill_buffer=64,
        target_update_freq=2000,
        polyak=0.0,
        ddqn=False,
        eps_start=1.0,
        eps_end=0.05,
        exploration_fraction=0.5,
    )
    return algo.replace(eval_callback=lambda algo, ts, rng: jnp.zeros(()))


def run_one(seeds: int, beams: int, steps: int, reps: int, capacity: int) -> dict:
    import jax

    algo = make_rejax(beams, steps, capacity)
    keys = jax.random.split(jax.random.PRNGKey(0), seeds)
    devices = jax.devices()
    if len(devices) > 1 and seeds % len(devices) == 0:  # seeds over the devices, as ours
        from jax.sharding import Mesh, NamedSharding, PartitionSpec

        keys = jax.device_put(keys, NamedSharding(Mesh(devices, ("runs",)), PartitionSpec("runs")))
    ts = jax.jit(jax.vmap(algo.init_state))(keys)
    train = jax.jit(jax.vmap(lambda ts: algo.train(train_state=ts)[0]), donate_argnums=0)
    t0 = time.perf_counter()
    ts = jax.block_until_ready(train(ts))
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        ts = jax.block_until_ready(train(ts))
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    assert int(ts.global_step[0]) == (reps + 1) * steps
    return {
        "peer": PEER,
        "seeds": seeds,
        "beams": beams,
        "transitions_per_s": seeds * steps / med,
        "median_chunk_s": med,
        "compile_s": compile_s,
        "jax": jax.__version__,
    }


def measure(
    seeds_list, beams_list, steps, reps, capacity, peer_python=None, ours=True, log=print
) -> list[dict]:
    """Ours and rejax for every (beams, seeds); rows with both figures and the ratio."""
    py = find_python("rejax", peer_python)
    rows = []
    for beams in beams_list:
        for seeds in seeds_list:
            row = {
                "seeds": seeds,
                "beams": beams,
                "steps": steps,
                "capacity": capacity,
                "ours": None,
            }
            if ours:
                row["ours"] = ours_train(seeds, beams, steps, reps, capacity)["transitions_per_s"]
            if py is None:
                row["peer"] = None
                row["peer_error"] = "rejax not installed (see bench/README.md)"
            else:
                try:
                    r = run_marked(
                        [
                            py,
                            __file__,
                            "--one",
                            f"{seeds},{beams}",
                            "--steps",
                            str(steps),
                            "--reps",
                            str(reps),
                            "--capacity",
                            str(capacity),
                        ],
                        env=device_env(cores()),
                    )
                    row["peer"] = r["transitions_per_s"]
                    row["peer_compile_s"] = r["compile_s"]
                except (RuntimeError, OSError) as e:
                    row["peer"], row["peer_error"] = None, str(e)
            row["ratio"] = row["ours"] / row["peer"] if row["peer"] and row["ours"] else None
            msg = f"{seeds:>3} seeds {beams:>3} beams: "
            if row["ours"]:
                msg += f"ours {row['ours']:>10,.0f}/s | "
            msg += (
                f"rejax {row['peer']:>10,.0f}/s"
                if row["peer"]
                else f"rejax: {row.get('peer_error')}"
            )
            if row["ratio"]:
                msg += f" | ours/rejax {row['ratio']:.1f}x"
            log(msg)
            rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 32])
    ap.add_argument("--beams", type=int, nargs="+", default=[24])
    ap.add_argument("--steps", type=int, default=2000, help="train steps per timed call")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--capacity", type=int, default=250_000, help="replay capacity per seed")
    ap.add_argument("--quick", action="store_true", help="500 steps, 2 reps, 20k capacity")
    ap.add_argument(
        "--peer-python", help="interpreter with rejax (default: this one or .venv-peers)"
    )
    ap.add_argument(
        "--no-ours", action="store_true", help="rejax only (bench/all.py measures ours once)"
    )
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.quick:
        args.steps, args.reps, args.capacity = 500, 2, 20_000
    if args.one:
        seeds, beams = map(int, args.one.split(","))
        print(
            MARK + json.dumps(run_one(seeds, beams, args.steps, args.reps, args.capacity)),
            flush=True,
        )
        return 0
    print(
        f"# rejax DQN vs jaxnav trainer, square4, {args.steps} steps per call, median of "
        f"{args.reps}, capacity {args.capacity}/seed; {machine()}",
        flush=True,
    )
    rows = measure(
        args.seeds,
        args.beams,
        args.steps,
        args.reps,
        args.capacity,
        args.peer_python,
        ours=not args.no_ours,
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
