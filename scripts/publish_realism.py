"""Merge the runs of a sim-to-sim campaign into a table page and its per-seed CSV.

Campaigns (``--campaign``):

* ``realism`` (default): ``scripts/sim2sim_realism.sh OUT``, one run per realism
  option, into docs/sim2sim_realism.{md,csv};
* ``wheel_limit``: ``scripts/sim2sim_wheel_limit.sh OUT``, runs trained without and
  with the burger's firmware wheel limits, tested in MuJoCo with them, into
  docs/sim2sim_wheel_limit.{md,csv}.

Reads OUT/<arm>/sim2sim/sim2sim.csv for every arm of the campaign and writes the CSV
(those rows, an ``option`` column first) and the page (the table, recomputed from that
CSV alone by ``jaxnav.report.sim2sim_tables.realism_markdown``, then how it was made:
the arms' overrides, the commit that ran them and the wall-clock of each step from its
files). Run from the repository root:
``python scripts/publish_realism.py OUT [--campaign NAME] [--dst PATH]``.
"""

import argparse
import csv
import json
import sys
from pathlib import Path

from jaxnav.core.rundir import csv_text
from jaxnav.report.sim2sim_tables import REALISM_COLUMNS, realism_markdown

# The realism campaign's options (scripts/sim2sim_realism.sh), by their directory's name.
OPTIONS = {
    "plain": "none (configs/paper_no_obstacles.yaml as it is)",
    "action_delay": "env.action_delay=true",
    "maze_scale": "env.maze_scale=[0.75,1.5]",
    "random_start": "env.random_start=true",
    "odom_noise": "env.odom_noise=[0.02,0.02]",
    "beam_dropout": "env.beam_dropout=0.05",
    "lidar_noise_std": "env.lidar_noise_std=0.02",
}
REALISM_MADE = (
    "`scripts/sim2sim_realism.sh OUT 16 5` trains configs/paper_no_obstacles.yaml "
    "once per option (16 seeds per strategy, 500 episodes), tests every policy "
    "greedily in jaxnav and in MuJoCo (`python -m jaxnav.sim2sim RUN --seeds 0 .. "
    "15 --episodes 5`), with the code at {commit}. The plain arm (`PLAIN=RUN_DIR`) "
    "is the first 16 seeds of the reproduction report's no-obstacle run (docs/report), "
    "trained a few commits earlier by the same training code. `python "
    "scripts/publish_realism.py OUT` wrote this page and the per-seed CSV beside "
    "it. Each MuJoCo test ran beside "
    "the next option's training on the same 2 cores, so the times below are "
    "slower than either alone."
)

# The wheel-limit campaign's arms (scripts/sim2sim_wheel_limit.sh): (training, MuJoCo).
WHEEL_LIMIT_ARMS = {
    "plain": "trained without the limit; MuJoCo with it (`--wheel-limit`)",
    "wheel_limit": "trained with `env.wheel_limit=true`; MuJoCo with it (`--wheel-limit`)",
    "plain_unlimited": "plain's policies; MuJoCo without the limit",
}
WHEEL_LIMIT_MADE = (
    "`scripts/sim2sim_wheel_limit.sh OUT {seeds} {episodes}` trains "
    "configs/paper_no_obstacles.yaml (500 episodes) without and with `env.wheel_limit=true`, "
    "{seeds} seeds per strategy, and tests every policy greedily in jaxnav (in the run's "
    "own settings, so with the limit for wheel_limit) and in MuJoCo (`python -m "
    "jaxnav.sim2sim RUN --wheel-limit --seeds 0 .. {last} --episodes {episodes}`: every "
    "command through the burger's firmware clipping, `jaxnav.world.kinematics`); "
    "plain_unlimited is plain's policies in MuJoCo without the limit, what the limit costs "
    "them. Code at {commit}; `python scripts/publish_realism.py OUT --campaign wheel_limit` "
    "wrote this page and the per-seed CSV beside it. A MuJoCo test ran beside the next "
    "step on the same 2 cores (shared with other work), so the times are slower than "
    "either alone. {seeds} seeds resolve only large differences: read the intervals."
)
CAMPAIGNS = {
    "realism": (
        OPTIONS,
        "docs/sim2sim_realism",
        "Which realism options narrow the sim-to-sim gap",
        REALISM_MADE,
    ),
    "wheel_limit": (
        WHEEL_LIMIT_ARMS,
        "docs/sim2sim_wheel_limit",
        "Training with the burger's firmware wheel limits, tested on a burger with them",
        WHEEL_LIMIT_MADE,
    ),
}


def main(src: str, campaign: str = "realism", dst: str | None = None) -> int:
    arms, default_dst, title, made_text = CAMPAIGNS[campaign]
    src_dir = Path(src)
    rows, made, seeds, episodes = [], [], set(), set()
    needed = [src_dir / "commit"]
    for name in arms:
        needed += [src_dir / name / "sim2sim" / "sim2sim.csv", src_dir / name / "sim2sim.log"]
    missing = [p for p in needed if not p.is_file()]
    if missing:
        script = "sim2sim_realism.sh" if campaign == "realism" else "sim2sim_wheel_limit.sh"
        print(f"no {missing[0]}: run scripts/{script} {src} first", file=sys.stderr)
        return 2
    for name, override in arms.items():
        path = src_dir / name / "sim2sim" / "sim2sim.csv"
        for r in csv.DictReader(path.open()):
            rows.append([name, *r.values()])
            seeds.add(int(r["seed"]))
            if r["simulator"] == "mujoco":
                episodes.add(int(r["episodes"]))
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
            else ("the report's run" if campaign == "realism" else "plain's run")
        )
        shown = f"`{override}`" if campaign == "realism" else override
        made.append(f"| {name} | {shown} | {train} | {mujoco_s / 60:.1f} min |")
    text = csv_text(REALISM_COLUMNS, rows)
    commit = (src_dir / "commit").read_text().strip()
    n, eps = len(seeds), "/".join(map(str, sorted(episodes)))
    how = made_text.format(commit=commit, seeds=n, last=n - 1, episodes=eps)
    option = "override" if campaign == "realism" else "arm"
    md = "\n".join(
        [
            f"# {title}",
            "",
            realism_markdown(text),
            "## How it was made",
            "",
            how,
            "",
            f"| option | {option} | training | MuJoCo test |",
            "|---|---|---|---|",
            *made,
            "",
        ]
    )
    out = Path(dst or default_dst)
    out.with_suffix(".csv").write_text(text)
    out.with_suffix(".md").write_text(md)
    print(f"wrote {out}.md and {out}.csv")
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", metavar="OUT", help="the campaign's directory")
    p.add_argument("--campaign", choices=sorted(CAMPAIGNS), default="realism")
    p.add_argument("--dst", help="the pages' path, no suffix (default the campaign's)")
    args = p.parse_args()
    sys.exit(main(args.out, args.campaign, args.dst))
