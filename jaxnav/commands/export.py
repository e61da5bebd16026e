"""``jaxnav export RUN_DIR [--strategy ebe] [--seed K | --best] [--out policy.npz]``

One trained policy of a run to a portable file (:mod:`jaxnav.robot.export` builds
and writes it), or ``--info POLICY``: an exported policy's metadata.
"""

from __future__ import annotations

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

import sys
from pathlib import Path

from jaxnav.core import cli, rundir
from jaxnav.core.config import load_config
from jaxnav.robot.deploy import Policy
from jaxnav.robot.export import best_seed, default_strategy, export_policy, save_policy


def default_out(run_dir: Path, strategy: str, seed: int | None) -> Path:
    """``policy-<arm>-seed<k>.npz`` in the working directory (``k``: the run's first seed
    by default)."""
    if seed is None:
        seed = load_config(str(run_dir / rundir.CONFIG)).seed
    arm = strategy.replace(" ", "-").replace("=", "")
    return Path(f"policy-{arm}-seed{seed}.npz")


def main(argv: list[str] | None = None) -> int:
    p = cli.Parser(
        prog="jaxnav export",
        description="Write one trained policy of a run to a portable .npz for a real robot, "
        "or (--info) print an exported policy's metadata.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", nargs="?", help="a finished training run")
    p.add_argument(
        "--strategy",
        default=None,
        help="ebe, epsilon_greedy or boltzmann (default: ebe where the run trained it, else "
        "its first arm); in a swept run, the arm as params.npz names it "
        "('ebe ebe_temperature=0.1')",
    )
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--seed", type=int, default=None, help="which seed (default: the run's first)"
    )
    which.add_argument(
        "--best",
        action="store_true",
        help="the seed with the best greedy success (jaxnav evaluate's test, else the last "
        "evaluation while training); says which and by how much",
    )
    p.add_argument(
        "--out", default=None, help="output file (default policy-<strategy>-seed<k>.npz)"
    )
    cli.add_overwrite(p, "the output file")
    p.add_argument("--info", metavar="POLICY", help="print the metadata of a policy file")
    args = p.parse_args(argv)
    if (args.run_dir is None) == (args.info is None):
        p.error("give RUN_DIR to export a policy, or --info POLICY to show one")

    def work() -> None:
        if args.info:
            for k, v in Policy.load(args.info).meta.items():
                if k not in ("config", "observation", "format", "version"):
                    print(f"{k}: {v}")
            return
        run_dir = rundir.existing(args.run_dir, finished=True)
        strategy = args.strategy or default_strategy(run_dir)
        seed = args.seed
        if args.best:
            seed, line = best_seed(run_dir, strategy)
            print(line)
        out = Path(args.out) if args.out else default_out(run_dir, strategy, seed)
        cli.check_output(out, args.overwrite)
        arrays = export_policy(run_dir, strategy, seed)
        policy = Policy.from_arrays(arrays)  # what the robot will load must load
        meta = policy.meta
        save_policy(arrays, out)
        if policy.observation == "normalised":
            features = ", normalised observation"
            if policy.scan_history:
                what = "each beam's change since " if policy.history_changes else ""
                features += f" with {what}the {policy.scan_history} scans before"
                if policy.history_turned:
                    features += " (turned to the heading now)"
            if policy.convs:
                channels = ", ".join(str(k.shape[-1]) for k, _ in policy.convs)
                features += f", circular convolutions over the scan ({channels} channels)"
        else:
            features = ", obstacle features" if policy.obstacle_obs else ""
        print(
            f"wrote {out} ({meta['strategy']} seed {meta['seed']}, {meta['n_beams']} beams"
            f"{features}, maze {meta['maze']}; format version {meta['version']})"
        )

    return cli.run(p.prog, work)


if __name__ == "__main__":
    sys.exit(main())
