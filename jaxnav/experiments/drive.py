"""A policy file played in any world, without training (``jaxnav drive``).

The file (``jaxnav export``'s, or a shipped one, :mod:`jaxnav.robot.shipped`) holds the
network and the config of the run that trained it. :func:`policy_run` writes that as a
run directory of one policy (its config for the one seed and strategy, its parameters in
``params.npz``), so the policy is tested exactly as a trained run's are
(:func:`jaxnav.experiments.evaluation.evaluate_to_dir`): in the world named, with the
oracle through the very same test, its greedy episodes recorded and drawn (trajectories
and a GIF, :mod:`jaxnav.report.plots`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from jaxnav.core import rundir
from jaxnav.core.config import dump_config, load_config
from jaxnav.core.errors import PolicyError
from jaxnav.experiments.evaluation import evaluate_to_dir
from jaxnav.report.plots import plot_test_episodes
from jaxnav.robot.deploy import Policy

RUN, EVAL, PLOTS = "run", "eval", "plots"  # the folders a drive writes in its --out


def policy_run(path: Path, out: Path) -> Path:
    """``out`` made a finished run directory of the one policy in the policy file
    ``path``: its run's config for that strategy and seed (a dueling head folded into
    its last layer, as the file holds it), ``params.npz`` and a summary."""
    Policy.load(path)  # a file that is not a policy is refused here, in one line
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    if "config" not in meta:
        raise PolicyError(f"{path} names no config (written before jaxnav kept one): re-export it")
    strategy, seed = str(meta["strategy"]).split(" ", 1)[0], int(meta["seed"])
    text_path = out / rundir.CONFIG
    out.mkdir(parents=True, exist_ok=True)
    rundir.atomic_write_text(text_path, meta["config"])
    cfg = load_config(
        str(text_path),
        [f"seed={seed}", "seeds=1", f"strategies=[{strategy}]", "dqn.dueling=false"],
    )
    cfg = cfg.at(())  # no sweep: the file holds one arm's policy
    rundir.atomic_write_text(text_path, dump_config(cfg))
    names = [*meta["layers"], *meta.get("norms", [])]
    names += list((meta.get("scan_conv") or {}).get("layers", []))
    params = {}
    for name in names:
        kinds = ("scale", "bias") if name.startswith("LayerNorm_") else ("kernel", "bias")
        for kind in kinds:
            key = rundir.params_key(strategy, seed, f"params/{name}/{kind}")
            params[key] = np.asarray(arrays[f"{name}/{kind}"], np.float32)
    rundir.atomic_write_npz(out / rundir.PARAMS, params)
    summary = {"policy_file": str(path), "strategy": strategy, "seed": seed, "diverged": []}
    rundir.atomic_write_text(out / rundir.SUMMARY, json.dumps(summary, indent=2) + "\n")
    return out


def drive(
    path: Path,
    world: str,
    out: Path,
    episodes: int,
    overrides: Sequence[str] = (),
    references: Sequence[str] = ("oracle",),
    say: Callable[[str], None] | None = None,
) -> tuple[Path, list[Path]]:
    """Play the policy of ``path`` for ``episodes`` greedy episodes in ``world`` (a
    built-in maze, a maze file or a map) beside ``references``, in the environment it
    trained in with ``overrides`` (``env.KEY=VALUE``). Returns the test's folder and the
    figures drawn (each test maze's trajectories and the GIF of its first episode)."""
    run = policy_run(path, out / RUN)
    tested = evaluate_to_dir(
        run,
        [world],
        episodes,
        out / EVAL,
        modes=("greedy",),
        references=references,
        say=say,
        overrides=overrides,
        family_splits=False,  # the world named only, whatever the policy trained on
    )
    (out / PLOTS).mkdir(exist_ok=True)
    # The trajectories' figures read the run's own eval/ folder.
    recorded = run / "eval"
    recorded.mkdir(exist_ok=True)
    for name in ("trajectories.npz", "results.csv"):
        rundir.atomic_write_bytes(recorded / name, (tested / name).read_bytes())
    drawn = plot_test_episodes(run, out / PLOTS, [world])
    return tested, drawn


__all__ = ["PLOTS", "drive", "policy_run"]
