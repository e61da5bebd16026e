"""Training throughput: transitions per second with learning, and peak memory.

Every transition is one environment step plus one gradient step on a batch of 64
(the paper config). Each (seeds, beams) case runs in its own subprocess so that its
peak RSS is its own; the time of a chunk of ``--steps`` scan steps is measured
after compilation, median of ``--reps`` repetitions.

    python bench/train_throughput.py                # 1, 8, 32 seeds x 24, 360 beams
    python bench/train_throughput.py --quick        # fewer steps, small buffer
    python bench/train_throughput.py --seeds 8 --beams 24
    python bench/train_throughput.py --seeds 32 --beams 24 --devices 1 2 4   # sharding

``--xla-flags`` measures each case once per set of extra XLA flags, one after the
other, each set its flags' names without the leading dashes, comma-separated, or
``none``: ``--xla-flags none xla_cpu_use_xnnpack=true none`` measures the default,
XNNPACK, then the default again.

``--devices`` forces that many CPU devices (XLA_FLAGS) and lays the seeds over them
with jaxnav's run sharding. The default is one device per core, as ``jaxnav train``
runs; ``--devices 1 2 4`` shows what the layout gains (devices beyond the core
count share cores, so they cannot be faster).

The replay buffer has the capacity of a full paper run (500 episodes x 500 steps)
unless --capacity says otherwise, so the memory column is that of a real run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time


def run_case(seeds: int, beams: int, steps: int, reps: int, capacity: int) -> dict:
    import jax
    import numpy as np

    from jaxnav.agent.replay import nbytes as buffer_bytes
    from jaxnav.agent.sharding import RunSharding
    from jaxnav.agent.trainer import run_inputs
    from jaxnav.core.config import load_config
    from jaxnav.dqn import make_trainer

    cfg = load_config(
        None,
        [
            f"seeds={seeds}",
            "strategies=[ebe]",
            f"env.n_beams={beams}",
            f"run.chunk_steps={steps}",
            f"dqn.buffer_size={capacity}",
        ],
    )
    tr = make_trainer(cfg)
    shard = RunSharding(cfg.n_runs)
    init = jax.jit(jax.vmap(tr.init), out_shardings=shard.sharding)
    # as jaxnav train compiles it: each device's runs as one batch
    chunk = jax.jit(
        shard.per_device(jax.vmap(tr.chunk), 1), donate_argnums=0, out_shardings=shard.sharding
    )
    ts = init(*shard.put(jax.tree.map(np.asarray, run_inputs(cfg))))
    t0 = time.perf_counter()
    ts, _ = chunk(ts)
    jax.block_until_ready(ts)
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        ts, _ = chunk(ts)
        jax.block_until_ready(ts)
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    return {
        "seeds": seeds,
        "beams": beams,
        "transitions_per_s": seeds * steps / med,
        "median_chunk_s": med,
        "compile_s": compile_s,
        "buffer_capacity": cfg.buffer_capacity,
        "buffer_mb_per_seed": buffer_bytes(cfg.buffer_capacity, tr.env.obs_size, 500) / 2**20,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "devices": shard.n_devices,
    }


def main() -> None:
    from common import cores, device_env

    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 8, 32])
    p.add_argument("--beams", type=int, nargs="+", default=[24, 360])
    p.add_argument("--steps", type=int, default=2000, help="scan steps per timed chunk")
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--capacity", type=int, default=250_000, help="replay capacity per seed")
    p.add_argument("--quick", action="store_true", help="500 steps, 2 reps, 20k capacity")
    p.add_argument(
        "--devices",
        type=int,
        nargs="+",
        default=[cores()],
        help="CPU device counts (default: one per core, as jaxnav train)",
    )
    p.add_argument(
        "--xla-flags",
        nargs="+",
        default=["none"],
        metavar="FLAGS",
        help="measure every case under each of these sets of extra XLA flags: "
        "names without the leading --, comma-separated, or none",
    )
    p.add_argument("--json", help="also write the results here")
    p.add_argument("--case", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.quick:
        args.steps, args.reps, args.capacity = 500, 2, 20_000
    if args.case:  # child process: one case, JSON on stdout
        seeds, beams = map(int, args.case.split(","))
        print(json.dumps(run_case(seeds, beams, args.steps, args.reps, args.capacity)))
        return

    import jax

    print(
        f"# train throughput: {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, "
        f"jax {jax.__version__} ({jax.default_backend()})"
    )
    print(
        f"# {args.steps} steps per chunk, median of {args.reps}, "
        f"replay capacity {args.capacity}/seed"
    )
    flagged = args.xla_flags != ["none"]
    print(
        ("| XLA flags " if flagged else "")
        + "| devices | seeds | beams | transitions/s | per seed | compile s | buffer MB/seed "
        "| peak RSS MB |"
    )
    print("|" + "---|" * (8 + flagged))
    results = []
    cases = [
        (d, b, s, f)
        for d in args.devices
        for b in args.beams
        for s in args.seeds
        for f in args.xla_flags
    ]
    for devices, beams, seeds, flags in cases:
        env = device_env(devices)
        if flags != "none":
            extra = " ".join("--" + f for f in flags.split(","))
            env["XLA_FLAGS"] = f"{env.get('XLA_FLAGS', '')} {extra}".strip()
        first = f"| {flags} " if flagged else ""
        cmd = [
            sys.executable,
            __file__,
            "--case",
            f"{seeds},{beams}",
            "--steps",
            str(args.steps),
            "--reps",
            str(args.reps),
            "--capacity",
            str(args.capacity),
        ]
        out = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if out.returncode != 0:
            print(
                f"{first}| {devices} | {seeds} | {beams} "
                f"| failed: {out.stderr.strip().splitlines()[-1]} |"
            )
            continue
        r = json.loads(out.stdout.strip().splitlines()[-1]) | {"xla_flags": flags}
        results.append(r)
        print(
            f"{first}| {devices} | {seeds} | {beams} | {r['transitions_per_s']:,.0f} "
            f"| {r['transitions_per_s'] / seeds:,.0f} "
            f"| {r['compile_s']:.1f} | {r['buffer_mb_per_seed']:.1f} | {r['peak_rss_mb']:,.0f} |",
            flush=True,
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
