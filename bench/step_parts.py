"""What each part of a training step costs: the step with parts taken out.

The chunk of ``jaxnav.train`` (64 runs, 24 beams, on one CPU device per core) is
timed as it is and with parts of its step replaced by stand-ins that do no work:

* ``learner``: no gradient step (parameters and optimiser unchanged; the replay
  sample goes with it);
* ``replay sample``: the batch is the buffer's first rows, not a random gather;
* ``environment``: the robot does not move or scan; episodes still end at the
  step limit;
* ``acting``: action 0, no forward pass, no exploration draw;
* ``guard``: the gradient step is applied without the check that loss and new
  parameters are finite, and without the selects that keep a run's parameters where
  no step was due;
* ``replay add``: nothing is stored;
* ``target sync``: the target network is never copied.

A variant's time against the full step's is what that part costs *inside* the
step, where XLA schedules and fuses it with the rest; ``all but the learner``
removes everything except the gradient step. Each variant runs in its own process
(compilation excluded, median of the chunk times of ``--rounds`` rounds; the
variants take turns within a round, so drift on a shared machine spreads over all of
them). The numbers each variant computes are meaningless; only the time is.

    python bench/step_parts.py
    python bench/step_parts.py --runs 64 --steps 1000 --rounds 3
    python bench/step_parts.py --variants "full step" "all but the learner"
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

from common import cores, device_env, machine

PARTS = (
    "learner",
    "replay sample",
    "environment",
    "acting",
    "guard",
    "replay add",
    "target sync",
)
VARIANTS = {
    "full step": (),
    **{f"no {p}": (p,) for p in PARTS},
    "all but the learner": tuple(p for p in PARTS if p != "learner"),
}


def _remove(parts: tuple[str, ...]) -> None:
    """Replace the named parts of jaxnav.dqn's step with stand-ins (before tracing)."""
    import functools

    import jax
    import jax.numpy as jnp
    import optax

    from jaxnav import dqn
    from jaxnav.agent import replay
    from jaxnav.env import NavEnv

    if "learner" in parts:

        def no_learner(network, d, ts, buffer, n_steps, run, keys, horizon):
            return ts.params, ts.opt_state, jnp.bool_(False), jnp.float32(jnp.nan), buffer

        dqn._learn = no_learner
    if "replay sample" in parts:

        def first_rows(buf, key, b):
            # the first records cut out before their fields are read: reading a field
            # of the whole buffer first (buf.obs[:b]) costs more than the sample it
            # stands in for
            head = buf.replace(records=buf.records[: b + 1])
            return replay.Batch(
                obs=head.obs[:b],
                action=head.action[:b].astype(jnp.int32),
                reward=head.reward[:b],
                next_obs=head.obs[1 : b + 1],
                terminated=head.terminated[:b],
            )

        replay.sample = first_rows
    if "environment" in parts:

        def standing(self, key, state, action, params):
            t = state.t + 1
            obs = jnp.zeros(self.obs_size, jnp.float32) + state.pos[0]
            truncated = t >= params.max_steps
            info = {"goal_reached": jnp.bool_(False), "collision": jnp.bool_(False)}
            info["final_obs"] = obs
            state = state.replace(t=jnp.where(truncated, 0, t))
            return obs, state, jnp.float32(1.0), jnp.bool_(False), truncated, info

        NavEnv.step = standing
    if "acting" in parts:

        def action_zero(network, config, ts, key):
            return jnp.int32(0), jnp.float32(0.0), jnp.bool_(True), jnp.float32(0.0)

        dqn._act = action_zero
    if "guard" in parts and "learner" not in parts:
        sample = replay.sample

        def unguarded(network, d, ts, buffer, n_steps, run, keys, horizon):
            h = ts.hyper
            k_sample, k_drop = keys
            batch = sample(buffer, k_sample, d.batch_size)
            loss_fn = functools.partial(dqn._loss, network, h)
            loss, grads = jax.value_and_grad(loss_fn)(ts.params, ts.target_params, batch, k_drop)
            updates, opt_state = dqn.optimizer_of(h).update(grads, ts.opt_state, ts.params)
            params = optax.apply_updates(ts.params, updates)
            return params, opt_state, jnp.bool_(False), loss, buffer

        dqn._learn = unguarded
    if "replay add" in parts:
        replay.add = lambda buf, *args, **kwargs: buf
    if "target sync" in parts:
        dqn._target_sync_due = lambda d, h, n_steps, done: jnp.bool_(False)


def run_case(parts: tuple[str, ...], runs: int, steps: int, reps: int) -> list[float]:
    """Seconds per step of ``reps`` chunks of ``steps`` steps, after a warm-up one."""
    _remove(parts)
    import jax
    import numpy as np

    from jaxnav.core.config import load_config
    from jaxnav.run.training import Run

    cfg = load_config(
        None,
        [f"seeds={runs // 2}", f"run.chunk_steps={steps}", "dqn.buffer_size=250000"],
    )
    run = Run(cfg, None, quiet=True)  # jaxnav.train's own programs, no files
    n = np.int32(steps)
    ts = run.fresh_state()
    chunk = run.chunk.lower(ts, n).compile()
    ts = jax.block_until_ready(chunk(ts, n)[0])  # warm-up, past learning_starts
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        ts = jax.block_until_ready(chunk(ts, n)[0])
        times.append((time.perf_counter() - t0) / steps)
    return times


def main() -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--runs", type=int, default=64, help="runs (half EBE, half epsilon-greedy)")
    p.add_argument("--steps", type=int, default=1000, help="steps per timed chunk")
    p.add_argument("--reps", type=int, default=2, help="timed chunks per process")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument(
        "--variants", nargs="+", choices=list(VARIANTS), help="only these (default: all)"
    )
    p.add_argument("--json", help="also write the results here")
    p.add_argument("--case", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.case is not None:  # child: one variant, JSON on stdout
        parts = tuple(json.loads(args.case))
        print(json.dumps(run_case(parts, args.runs, args.steps, args.reps)))
        return 0

    print(f"# step parts: {machine()}, {args.runs} runs, 24 beams, {cores()} devices", flush=True)
    chosen = {v: VARIANTS[v] for v in args.variants or VARIANTS}
    times: dict[str, list[float]] = {v: [] for v in chosen}
    for _ in range(args.rounds):
        for name, parts in chosen.items():
            cmd = [sys.executable, __file__, "--case", json.dumps(parts)]
            cmd += ["--runs", str(args.runs), "--steps", str(args.steps), "--reps", str(args.reps)]
            out = subprocess.run(
                cmd, capture_output=True, text=True, env=device_env(cores()), check=True
            )
            times[name] += json.loads(out.stdout.strip().splitlines()[-1])
    full = statistics.median(times.get("full step") or next(iter(times.values())))
    print("| step | ms per step | transitions/s | share of the full step's time |")
    print("|---|---|---|---|")
    rows = []
    for name, ts in times.items():
        med = statistics.median(ts)
        rows.append({"variant": name, "s_per_step": med, "transitions_per_s": args.runs / med})
        print(f"| {name} | {1000 * med:.3f} | {args.runs / med:,.0f} | {100 * med / full:.0f}% |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
