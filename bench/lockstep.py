"""How much lockstep costs a finished run, and what compacting the batch would win.

All runs of a config advance together, one chunk of ``run.chunk_steps`` env steps at
a time; a run that has finished its episodes is still computed (as a no-op) until
the last one finishes. From a finished run's ``metrics.csv`` (each run's total env
steps), this replays the host loop's schedule and prints the share of computed
run-steps that were real steps:

* **lockstep**: what ``jaxnav train`` does (each chunk as long as the longest
  remaining run needs, at most ``chunk_steps``); ``summary.json``'s
  ``lockstep_useful`` is the same figure, measured;
* **compacted**: at each chunk boundary, the finished runs moved out of the batch,
  each device's share shrunk to the smallest power-of-two fraction that holds its
  runs still training (one compiled program per size, runs laid over the devices
  in blocks, as ``jaxnav.agent.sharding`` does);

and the run-steps compacting would save, which bounds the time it would save (a
smaller batch costs more per run-step, and each new size compiles once).

    python bench/lockstep.py docs/report/paper_no_obstacles docs/report/paper_obstacles
    python bench/lockstep.py docs/report/paper_no_obstacles --episodes 100 --seeds 16
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections import defaultdict
from pathlib import Path

import yaml


def run_lengths(run_dir: Path, episodes: int | None = None, seeds: int | None = None) -> list[int]:
    """Each run's total env steps, in the run axis's order of first appearance; of its
    first ``episodes`` episodes only, and of the first ``seeds`` seeds of each strategy
    only, when given (the schedule a shorter or smaller run of the same config had had)."""
    steps: dict[tuple, int] = defaultdict(int)
    with (run_dir / "metrics.csv").open() as f:
        for row in csv.DictReader(f):
            if episodes is not None and int(row["episode"]) >= episodes:
                continue
            if seeds is not None and int(row["seed"]) >= seeds:
                continue
            steps[(row["strategy"], row["seed"])] += int(row["length"])
    return list(steps.values())


def schedule(lengths: list[int], chunk: int, devices: int, compact: bool) -> float:
    """Share of computed run-steps that are real steps under the host loop's schedule."""
    n = len(lengths)
    per = -(-n // devices)  # runs per device (the last block may be padded)
    done = [0] * n
    computed = 0
    while any(d < length for d, length in zip(done, lengths)):
        left = [length - d for d, length in zip(done, lengths)]
        steps = min(chunk, max(left))
        width = per
        if compact:
            busiest = max(
                sum(1 for r in range(b * per, min((b + 1) * per, n)) if left[r] > 0)
                for b in range(devices)
            )
            while width % 2 == 0 and width // 2 >= busiest:
                width //= 2
        computed += steps * width * devices
        done = [min(d + steps, length) for d, length in zip(done, lengths)]
    return sum(lengths) / computed


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dirs", nargs="+", type=Path)
    ap.add_argument("--devices", type=int, default=2, help="devices the runs are laid over")
    ap.add_argument("--episodes", type=int, help="only each run's first EPISODES episodes")
    ap.add_argument("--seeds", type=int, help="only seeds 0 to SEEDS-1 of each strategy")
    args = ap.parse_args(argv)
    print(
        "| run | runs | steps per run (min, median, max) | real steps, lockstep | real steps, "
        "compacted | run-steps saved |"
    )
    print("|---|--:|---|--:|--:|--:|")
    for d in args.run_dirs:
        lengths = run_lengths(d, args.episodes, args.seeds)
        chunk = yaml.safe_load((d / "config.yaml").read_text())["run"]["chunk_steps"]
        s = sorted(lengths)
        shares = [schedule(lengths, chunk, args.devices, c) for c in (False, True)]
        print(
            f"| {d} | {len(lengths)} | {s[0]:,}, {s[len(s) // 2]:,}, {s[-1]:,} "
            f"| {100 * shares[0]:.1f}% | {100 * shares[1]:.1f}% "
            f"| {100 * (1 - shares[0] / shares[1]):.1f}% |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
