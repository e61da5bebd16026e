"""What a config's training step costs, with override variants side by side.

Each variant is the config with its overrides (a quoted, space-separated list; ``-``
for none). Every measurement is a fresh subprocess that builds the config's trainer
(any agent), compiles one chunk of ``--chunk`` env steps per run over all of the
config's runs (vmapped, on one device, without the host loop, evaluations or
logging), then times ``--chunks`` more and keeps their median. The variants are
measured in rounds, A B C A B C ..., ``--reps`` rounds, and the table reports the
median over rounds of each variant's env steps per second (all runs together), its
compile seconds and its cost relative to the first variant.

    python bench/config_step.py drive_sac_stage4 \\
        "sac.shared_torso=false sac.hidden=[128,128] sac.num_envs=32 sac.updates=1" \\
        "sac.num_envs=32 sac.updates=1"

It times the learning step, not time to a policy: pair it with
``bench/time_to_solve.py``, which times whole commands to the oracle's line.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys

from common import MARK, run_marked


def measure(config: str, overrides: list[str], chunk: int, chunks: int) -> dict:
    """One variant in this process: {steps_per_s, compile_s}."""
    import time

    import jax

    from jaxnav.agent.trainer import run_inputs
    from jaxnav.core.config import load_config
    from jaxnav.run.training import trainer_of

    cfg = load_config(config, [f"run.chunk_steps={chunk}", *overrides])
    trainer = trainer_of(cfg)
    init = jax.jit(jax.vmap(trainer.init))
    step = jax.jit(jax.vmap(trainer.chunk, in_axes=(0, None)), donate_argnums=0)
    state = init(*run_inputs(cfg))
    t = time.perf_counter()
    state, _ = step(state, None)
    jax.block_until_ready(state)
    compile_s = time.perf_counter() - t
    times = []
    for _ in range(chunks):
        t = time.perf_counter()
        state, _ = step(state, None)
        jax.block_until_ready(state)
        times.append(time.perf_counter() - t)
    steps = trainer.chunk_length * cfg.n_runs
    return {"steps_per_s": steps / statistics.median(times), "compile_s": compile_s}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("config")
    p.add_argument("variants", nargs="+", help="quoted override lists; '-' for none")
    p.add_argument("--chunk", type=int, default=4096, help="env steps per run per timed chunk")
    p.add_argument("--chunks", type=int, default=3, help="timed chunks per measurement")
    p.add_argument("--reps", type=int, default=2, help="rounds over the variants")
    p.add_argument("--case", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.case is not None:
        overrides = [] if a.case == "-" else a.case.split()
        print(MARK + json.dumps(measure(a.config, overrides, a.chunk, a.chunks)))
        return
    got: dict[str, list[dict]] = {v: [] for v in a.variants}
    for _ in range(a.reps):
        for v in a.variants:
            cmd = [sys.executable, __file__, a.config, "-", "--case", v]
            cmd += ["--chunk", str(a.chunk), "--chunks", str(a.chunks)]
            got[v].append(run_marked(cmd))
    first = statistics.median(r["steps_per_s"] for r in got[a.variants[0]])
    print(f"{a.config}: env steps per second of all its runs, median of {a.reps} rounds")
    print("| overrides | env steps / s | compile (s) | time per step vs the first |")
    print("|---|--:|--:|--:|")
    for v in a.variants:
        rate = statistics.median(r["steps_per_s"] for r in got[v])
        comp = statistics.median(r["compile_s"] for r in got[v])
        print(f"| `{v}` | {rate:,.0f} | {comp:.1f} | {first / rate:.2f} |")


if __name__ == "__main__":
    main()
