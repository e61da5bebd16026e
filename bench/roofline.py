"""How close the trainer gets to this CPU's limit: learner FLOPs against matmul peak.

The limit is the float32 matmul peak of this machine, measured with JAX in the same
run (a large square ``jnp.dot``, median of ``--reps`` after a warm-up). The work is
the learner's arithmetic per transition, counted from the config:

* acting: one forward pass of the online net on 1 observation;
* learning: forward passes of the online and the target net on the batch (64 each),
  and the online net's backward pass, counted as 2 forward passes;
* RMSprop: 9 FLOPs per parameter (square, two scalings and a sum for the second
  moment; sqrt, eps, divide, learning rate, apply).

The backward pass counted as two forward passes is the usual model-FLOPs convention
(as in "6N per token"); the compiled step skips the first layer's input gradient,
which nothing needs, so it executes less: at 360 beams about 21% less, at 24 beams
about 7%. Both fractions are printed; the table uses the convention.

A forward pass on one observation counts 2 FLOPs per multiply-add plus the bias
adds; ReLU, dropout, the TD target, argmax, the environment and the buffer are left
out (they are O(width) or not learner arithmetic). The fraction printed is the
share of the machine's dense float32 rate that goes into network arithmetic;
everything else in a training step counts as overhead against it.

The learner alone is also measured: the same gradient step (``jaxnav.dqn``'s loss,
dropout and RMSprop update, vmapped over the runs and laid over the devices as
``jaxnav train`` lays them) on a fixed batch per run, with no environment, acting
or replay. Its rate bounds what the whole trainer can reach on this machine with
this arithmetic: whatever else a step does only adds to it.

    python bench/roofline.py               # 32 seeds, 24 and 360 beams
    python bench/roofline.py --quick
    python bench/roofline.py --seeds 64 --beams 24      # the speed target's case
    python bench/roofline.py --no-ours --json r.json   # peak and FLOP counts only
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time

from common import cores, device_env, machine, ours_train


def matmul_peak(n: int = 2048, reps: int = 5) -> dict:
    """Median GFLOP/s of an n x n float32 ``jnp.dot`` (compiled, warmed up)."""
    import jax
    import jax.numpy as jnp

    ka, kb = jax.random.split(jax.random.PRNGKey(0))
    a = jax.random.normal(ka, (n, n), jnp.float32)
    b = jax.random.normal(kb, (n, n), jnp.float32)
    dot = jax.jit(jnp.dot)
    jax.block_until_ready(dot(a, b))
    jax.block_until_ready(dot(a, b))
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        jax.block_until_ready(dot(a, b))
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    return {
        "n": n,
        "median_s": med,
        "gflops": 2 * n**3 / med / 1e9,
        "best_gflops": 2 * n**3 / min(times) / 1e9,
    }


def learner_flops(beams: int, overrides: tuple[str, ...] = ()) -> dict:
    """FLOPs per transition of the learner for the default config at ``beams`` beams."""
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config

    cfg = load_config(None, [f"env.n_beams={beams}", *overrides])
    env, _ = from_config(cfg)
    widths = [env.obs_size, *cfg.dqn.hidden, env.num_actions]
    layers = list(zip(widths[:-1], widths[1:]))
    fwd = sum(2 * i * o + o for i, o in layers)  # per observation
    params = sum(i * o + o for i, o in layers)
    batch = cfg.dqn.batch_size
    parts = {
        "act_forward": fwd,
        "online_forward": batch * fwd,
        "target_forward": batch * fwd,
        "online_backward": 2 * batch * fwd,
        "rmsprop": 9 * params,
    }
    # What the compiled step executes: the backward pass forms every layer's weight
    # gradient but the input gradient only of layers after the first.
    executed = dict(
        parts,
        online_backward=batch
        * (sum(2 * i * o + o for i, o in layers) + sum(2 * i * o for i, o in layers[1:])),
    )
    return {
        "beams": beams,
        "obs_dim": env.obs_size,
        "layers": widths,
        "params": params,
        "forward_flops": fwd,
        "parts": parts,
        "flops_per_transition": sum(parts.values()),
        "executed_flops_per_transition": sum(executed.values()),
    }


def learner_alone(seeds: int, beams: int, steps: int, reps: int) -> dict:
    """Gradient steps per second of the learner by itself for ``seeds`` runs (of EBE,
    as ``train_throughput.py`` counts them): ``steps`` steps in one compiled loop,
    median of ``reps`` after a compiling call."""
    import functools

    import jax
    import jax.numpy as jnp
    import numpy as np
    import optax

    from jaxnav import dqn
    from jaxnav.agent.replay import Batch
    from jaxnav.agent.sharding import RunSharding
    from jaxnav.agent.trainer import run_inputs
    from jaxnav.core.config import load_config
    from jaxnav.env import from_config

    cfg = load_config(None, [f"seeds={seeds}", "strategies=[ebe]", f"env.n_beams={beams}"])
    env, _ = from_config(cfg)
    d = cfg.dqn
    network = dqn.QNetwork(env.num_actions, tuple(d.hidden), d.dropout)
    inputs = run_inputs(cfg)

    def init(key, hyper):
        k_net, k_batch = jax.random.split(key)
        params = network.init(k_net, jnp.zeros((1, env.obs_size)))
        ko, kn, ka, kr = jax.random.split(k_batch, 4)
        batch = Batch(
            obs=jax.random.uniform(ko, (d.batch_size, env.obs_size)),
            action=jax.random.randint(ka, (d.batch_size,), 0, env.num_actions),
            reward=jax.random.normal(kr, (d.batch_size,)),
            next_obs=jax.random.uniform(kn, (d.batch_size, env.obs_size)),
            terminated=jnp.zeros(d.batch_size, bool),
        )
        opt_state = dqn.optimizer_of(hyper).init(params)
        return params, params, opt_state, batch, key

    def learn(state, hyper):
        def body(_, carry):
            params, target, opt_state, batch, key = carry
            key, k_drop = jax.random.split(key)
            loss_fn = functools.partial(dqn.batch_loss, network, hyper)
            _, grads = jax.value_and_grad(loss_fn)(params, target, batch, k_drop)
            updates, opt_state = dqn.optimizer_of(hyper).update(grads, opt_state, params)
            return optax.apply_updates(params, updates), target, opt_state, batch, key

        return jax.lax.fori_loop(0, steps, body, state)

    shard = RunSharding(cfg.n_runs)
    keys, _, hypers = shard.put(jax.tree.map(np.asarray, inputs))
    state = jax.jit(jax.vmap(init), out_shardings=shard.sharding)(keys, hypers)
    run = jax.jit(jax.vmap(learn), donate_argnums=0, out_shardings=shard.sharding)
    state = jax.block_until_ready(run(state, hypers))
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        state = jax.block_until_ready(run(state, hypers))
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    return {"runs": cfg.n_runs, "beams": beams, "steps_per_s": cfg.n_runs * steps / med}


def learner_alone_child(seeds: int, beams: int, steps: int, reps: int) -> dict:
    """:func:`learner_alone` in its own process, on one CPU device per core."""
    cmd = [sys.executable, __file__, "--learner-case", f"{seeds},{beams},{steps},{reps}"]
    out = subprocess.run(cmd, capture_output=True, text=True, env=device_env(cores()), check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--beams", type=int, nargs="+", default=[24, 360])
    ap.add_argument("--seeds", type=int, default=32)
    ap.add_argument(
        "--n", type=int, nargs="+", default=[2048, 4096], help="matmul sizes (best median counts)"
    )
    ap.add_argument("--peak-reps", type=int, default=5)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--capacity", type=int, default=250_000)
    ap.add_argument(
        "--quick", action="store_true", help="2048 only, 3 reps; 500 steps, 20k capacity"
    )
    ap.add_argument("--no-ours", action="store_true", help="peak and FLOP counts only")
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument("--learner-case", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.learner_case:  # child process: the learner alone, JSON on stdout
        print(json.dumps(learner_alone(*map(int, args.learner_case.split(",")))))
        return 0
    if args.quick:
        args.n, args.peak_reps, args.steps, args.reps, args.capacity = [2048], 3, 500, 2, 20_000

    print(f"# roofline: {machine()}", flush=True)
    peaks = [matmul_peak(n, args.peak_reps) for n in args.n]
    for p in peaks:
        print(
            f"float32 matmul {p['n']}x{p['n']}: {p['gflops']:,.1f} GFLOP/s (median of "
            f"{args.peak_reps}; best {p['best_gflops']:,.1f})",
            flush=True,
        )
    peak = max(p["gflops"] for p in peaks)
    rows = []
    for beams in args.beams:
        f = learner_flops(beams)
        row = dict(f, seeds=args.seeds, peak_gflops=peak)
        print(
            f"{beams} beams: obs {f['obs_dim']}, network {'-'.join(map(str, f['layers']))}, "
            f"{f['params']:,} parameters, {f['flops_per_transition'] / 1e6:.2f} MFLOP/transition "
            f"({', '.join(f'{k} {v / 1e6:.2f}M' for k, v in f['parts'].items())})",
            flush=True,
        )
        if not args.no_ours:
            alone = learner_alone_child(args.seeds, beams, args.steps, args.reps)
            alone_gflops = alone["steps_per_s"] * f["flops_per_transition"] / 1e9
            row.update(learner_alone_per_s=alone["steps_per_s"], learner_alone_gflops=alone_gflops)
            print(
                f"  the learner alone, {alone['runs']} runs: {alone['steps_per_s']:,.0f} "
                f"gradient steps/s = {alone_gflops:,.2f} GFLOP/s = "
                f"{100 * alone_gflops / peak:.1f}% of {peak:,.0f} GFLOP/s",
                flush=True,
            )
            tps = ours_train(args.seeds, beams, args.steps, args.reps, args.capacity)[
                "transitions_per_s"
            ]
            achieved = tps * f["flops_per_transition"] / 1e9
            executed = tps * f["executed_flops_per_transition"] / 1e9
            row.update(
                transitions_per_s=tps,
                achieved_gflops=achieved,
                fraction=achieved / peak,
                executed_gflops=executed,
                executed_fraction=executed / peak,
            )
            print(
                f"  ours, {args.seeds} seeds: {tps:,.0f} transitions/s x "
                f"{f['flops_per_transition'] / 1e6:.2f} MFLOP = {achieved:,.2f} GFLOP/s = "
                f"{100 * achieved / peak:.1f}% of {peak:,.0f} GFLOP/s (executed arithmetic, "
                f"{f['executed_flops_per_transition'] / 1e6:.2f} MFLOP: "
                f"{100 * executed / peak:.1f}%)",
                flush=True,
            )
        rows.append(row)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"peaks": peaks, "peak_gflops": peak, "rows": rows}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
