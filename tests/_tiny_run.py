"""One tiny training run shared by the evaluation, plot and report tests.

It is exactly the no-obstacle experiment of ``jaxnav reproduce``
with :data:`REPRODUCE_TINY`, so the report test reuses it (``--resume``) and every
evaluation of it shares one compiled rollout: compiling dominates these tests.
"""

from __future__ import annotations

from jaxnav.experiments.reproduce import experiment_config
from jaxnav.run.launch import train_new

REPRODUCE_TINY = [
    "--quick",
    "--seeds",
    "2",
    "--episodes",
    "4",
    "--max-steps",
    "60",
    "--test-episodes",
    "2",
]

_RUNS: dict = {}


def tiny_config():
    """paper_no_obstacles with 2 seeds, 4 episodes of 60 steps, 2 test episodes."""
    return experiment_config(
        "paper_no_obstacles", seeds=2, episodes=4, max_steps=60, test_episodes=2
    )


def tiny_run(tmp_path_factory):
    """(config, run directory) of the shared tiny run, trained on first use."""
    if "run" not in _RUNS:
        cfg = tiny_config()
        out = tmp_path_factory.mktemp("tiny") / "paper_no_obstacles"
        train_new(cfg, out, quiet=True)
        _RUNS["run"] = (cfg, out)
    return _RUNS["run"]
