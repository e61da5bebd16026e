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

    python bench/roofline.py               # 32 seeds, 24 and 360 beams
    python bench/roofline.py --quick
    python bench/roofline.py --no-ours --json r.json   # peak and FLOP counts only
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

from common import machine, ours_train


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
    from jaxnav.config import load_config
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
    args = ap.parse_args(argv)
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
