"""What a sweep point costs: one compiled program over strategy x point x seed
against the same number of runs as seeds of one setting, and against the points run
as separate programs one after another.

Cases (each in its own subprocess, median of ``--reps`` timed chunks after the
first, which compiles; the cases alternate, so a busy machine slows them alike):

- ``sweep``: strategies [ebe, epsilon_greedy] x 8 points (dqn.lr 4 values x dqn.gamma
  2 values) x ``--seeds`` seeds, one program;
- ``seeds``: strategies [ebe, epsilon_greedy] x 8 x ``--seeds`` seeds of one setting,
  the same number of runs;
- ``separate``: one point's runs (2 strategies x ``--seeds`` seeds) as its own
  program; 8 of them one after another cost 8 compilations and 8 such chunks.

    python bench/sweep_cost.py            # 8 seeds: 128 runs, 1000-step chunks
    python bench/sweep_cost.py --quick    # 2 seeds: 32 runs, 200-step chunks
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

SWEEP = ["sweep.dqn.lr=[0.00025,0.0005,0.001,0.002]", "sweep.dqn.gamma=[0.9,0.99]"]
POINTS = 8


def run_case(case: str, seeds: int, steps: int, reps: int) -> dict:
    import jax
    import numpy as np

    from jaxnav.core.config import load_config
    from jaxnav.run.training import Run

    base = [
        "strategies=[ebe,epsilon_greedy]",
        f"run.chunk_steps={steps}",
        "dqn.buffer_size=20000",
    ]
    items = {
        "sweep": [*base, f"seeds={seeds}", *SWEEP],
        "seeds": [*base, f"seeds={seeds * POINTS}"],
        "separate": [*base, f"seeds={seeds}"],
    }[case]
    t0 = time.perf_counter()
    cfg = load_config(None, items)
    run = Run(cfg, None, quiet=True)  # jaxnav train's own programs, no files
    chunk = run.chunk
    ts = run.fresh_state()
    ts, _ = chunk(ts, np.int32(steps))
    jax.block_until_ready(ts)
    first_s = time.perf_counter() - t0  # what a user waits for before steady state
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        ts, _ = chunk(ts, np.int32(steps))
        jax.block_until_ready(ts)
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    return {
        "case": case,
        "runs": cfg.n_runs,
        "points": len(cfg.points()),
        "transitions_per_s": cfg.n_runs * steps / med,
        "chunk_s": med,
        "first_chunk_s": first_s,
        "programs_compiled": chunk._cache_size(),
    }


def main() -> None:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--seeds", type=int, default=8, help="seeds per strategy and point")
    p.add_argument("--steps", type=int, default=1000, help="scan steps per timed chunk")
    p.add_argument("--reps", type=int, default=3, help="timed chunks per case and round")
    p.add_argument("--rounds", type=int, default=2, help="alternating rounds of the cases")
    p.add_argument("--quick", action="store_true", help="2 seeds, 200 steps, 1 round")
    p.add_argument("--json", help="also write the results here")
    p.add_argument("--case", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.quick:
        args.seeds, args.steps, args.rounds = 2, 200, 1
    if args.case:
        print(json.dumps(run_case(args.case, args.seeds, args.steps, args.reps)))
        return

    print(
        f"# sweep cost: {platform.machine()}, {os.cpu_count()} cores; {args.seeds} seeds x "
        f"2 strategies x {POINTS} points; {args.steps}-step chunks, median of {args.reps} "
        f"per case and round, {args.rounds} alternating rounds"
    )
    results: dict[str, list[dict]] = {}
    for _ in range(args.rounds):
        for case in ("sweep", "seeds", "separate"):
            cmd = [sys.executable, __file__, "--case", case, f"--seeds={args.seeds}"]
            cmd += [f"--steps={args.steps}", f"--reps={args.reps}"]
            out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
            results.setdefault(case, []).append(json.loads(out.strip().splitlines()[-1]))

    def med(case: str, key: str) -> float:
        return statistics.median(r[key] for r in results[case])

    sweep_tps, seeds_tps = med("sweep", "transitions_per_s"), med("seeds", "transitions_per_s")
    sep_chunk, sep_first = med("separate", "chunk_s"), med("separate", "first_chunk_s")
    runs = results["sweep"][0]["runs"]
    print(f"{'case':<34} {'runs':>5} {'transitions/s':>14} {'first chunk s':>14} {'programs':>9}")
    for case, label in (
        ("sweep", f"one program, {POINTS} points"),
        ("seeds", "one program, seeds of one setting"),
        ("separate", "one point alone"),
    ):
        r = results[case][0]
        print(
            f"{label:<34} {r['runs']:>5} {med(case, 'transitions_per_s'):>14,.0f} "
            f"{med(case, 'first_chunk_s'):>14.1f} {r['programs_compiled']:>9}"
        )
    per_round = [
        a["transitions_per_s"] / b["transitions_per_s"]
        for a, b in zip(results["sweep"], results["seeds"])
    ]
    print(
        f"sweep / seeds transitions per s: {sweep_tps / seeds_tps:.2f} "
        f"(each round, side by side: {', '.join(f'{r:.2f}' for r in per_round)})"
    )
    # POINTS separate programs, one after another: each compiles, then steps its runs.
    separate_s = POINTS * sep_first + POINTS * (args.reps - 1) * sep_chunk
    together_s = med("sweep", "first_chunk_s") + (args.reps - 1) * med("sweep", "chunk_s")
    print(
        f"{POINTS} points x {args.reps} chunks: one program {together_s:.1f} s, "
        f"{POINTS} separate programs one after another {separate_s:.1f} s "
        f"({separate_s / together_s:.1f}x), {runs} runs"
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
