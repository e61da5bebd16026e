"""Merge the runs of ``scripts/sim2sim_realism.sh OUT`` into docs/sim2sim_realism.

Reads OUT/<option>/sim2sim/sim2sim.csv for every option the campaign trains and
writes docs/sim2sim_realism.csv (those rows, an ``option`` column first) and
docs/sim2sim_realism.md (the table, recomputed from that CSV alone by
``jaxnav.report.sim2sim_tables.realism_markdown``, then how it was made: the options' overrides,
the commit that ran them and the wall-clock of each step from its files). Run from the
repository root: ``python scripts/publish_realism.py OUT [--dst PATH]``.
"""

import argparse
import csv
import json
import sys
from pathlib import Path

from jaxnav.core.rundir import csv_text
from jaxnav.report.sim2sim_tables import REALISM_COLUMNS, realism_markdown

# The campaign's options (scripts/sim2sim_realism.sh), by the name of their directory.
OPTIONS = {
    "plain": "none (configs/paper_no_obstacles.yaml as it is)",
    "action_delay": "env.action_delay=true",
    "maze_scale": "env.maze_scale=[0.75,1.5]",
    "random_start": "env.random_start=true",
    "odom_noise": "env.odom_noise=[0.02,0.02]",
    "beam_dropout": "env.beam_dropout=0.05",
    "lidar_noise_std": "env.lidar_noise_std=0.02",
}


def main(src: str, dst: str = "docs/sim2sim_realism") -> int:
    src_dir = Path(src)
    rows, made = [], []
    needed = [src_dir / "commit"]
    for name in OPTIONS:
        needed += [src_dir / name / "sim2sim" / "sim2sim.csv", src_dir / name / "sim2sim.log"]
    missing = [p for p in needed if not p.is_file()]
    if missing:
        print(f"no {missing[0]}: run scripts/sim2sim_realism.sh {src} first", file=sys.stderr)
        return 2
    for name, override in OPTIONS.items():
        path = src_dir / name / "sim2sim" / "sim2sim.csv"
        rows += [[name, *r.values()] for r in csv.DictReader(path.open())]
        log = (src_dir / name / "sim2sim.log").read_text().strip().splitlines()
        mujoco_s = sum(
            int(line.rsplit(", ", 1)[1].removesuffix(" s"))
            for line in log
            if " in MuJoCo, " in line
        )
        summary = src_dir / name / "summary.json"
        train = (
            f"{json.loads(summary.read_text())['wall_clock_s'] / 60:.1f} min of training"
            if summary.is_file()
            else "the report's run"
        )
        made.append(f"| {name} | `{override}` | {train} | {mujoco_s / 60:.1f} min |")
    text = csv_text(REALISM_COLUMNS, rows)
    commit = (src_dir / "commit").read_text().strip()
    md = "\n".join(
        [
            "# Which realism options narrow the sim-to-sim gap",
            "",
            realism_markdown(text),
            "## How it was made",
            "",
            "`scripts/sim2sim_realism.sh OUT 16 5` trains configs/paper_no_obstacles.yaml "
            "once per option (16 seeds per strategy, 500 episodes), tests every policy "
            "greedily in jaxnav and in MuJoCo (`python -m jaxnav.sim2sim RUN --seeds 0 .. "
            f"15 --episodes 5`), with the code at {commit}. The plain arm (`PLAIN=RUN_DIR`) "
            "is the first 16 seeds of the reproduction report's no-obstacle run (docs/report), "
            "trained a few commits earlier by the same training code. `python "
            "scripts/publish_realism.py OUT` wrote this page and the per-seed CSV beside "
            "it. Each MuJoCo test ran beside "
            "the next option's training on the same 2 cores, so the times below are "
            "slower than either alone.",
            "",
            "| option | override | training | MuJoCo test |",
            "|---|---|---|---|",
            *made,
            "",
        ]
    )
    out = Path(dst)
    out.with_suffix(".csv").write_text(text)
    out.with_suffix(".md").write_text(md)
    print(f"wrote {out}.md and {out}.csv")
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", metavar="OUT", help="the campaign's directory")
    p.add_argument("--dst", default="docs/sim2sim_realism", help="the pages' path, no suffix")
    args = p.parse_args()
    sys.exit(main(args.out, args.dst))
