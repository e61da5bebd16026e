"""Many drawn test worlds, each played once by every policy: the mean success over the
worlds and over their worst tenth, as JaxNav's sampling-for-learnability study reports
them (Rutherford et al. 2024: 10,000 sampled levels, the mean and the worst 10%).

A run trained on drawn mazes (a family, or a mix of worlds) is tested on ``n`` layouts
of its test split, drawn from one fixed key so every policy and the oracle meet the
same worlds. Each layout is a *level*: the robot at the layout's start, its first goal
the layout's own; a level counts as solved by a policy when its first goal attempt
reaches the goal (within the attempt limit, without a collision). A level's success
is the share of the run's policies (its seeds) that solve it; the table gives the mean
over levels and the mean of the worst tenth, each with a 95% bootstrap interval over
levels, beside the oracle's on the same levels (what the levels allow).

A reference driver plays each level once, in one seat: a level is one start and one
goal, and a planner that sees the map drives it the same way from any seat, so 16 seats
(one per seed, as in the other tests) would play it 16 times over. Its level success is
0 or 1. The oracle's test costs about 50 times a policy's per step (docs/benchmarks.md):
in one seat a test of 1,000 levels takes minutes instead of most of an hour.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

import jax
import numpy as np

from jaxnav.core import rundir
from jaxnav.core.errors import JaxnavError
from jaxnav.env import from_config
from jaxnav.experiments.baselines import in_place_of
from jaxnav.experiments.evaluation import LoadedRun, load_run
from jaxnav.experiments.rollout import Policies, run_tests
from jaxnav.report.navigation import SUCCESS, run_attempts
from jaxnav.world.layouts import BANK_BATCH

LEVEL_SALT = 0x1E7E1  # the levels' key, apart from training's banks and the tests' keys
WORST = 0.1  # the worst tenth of the levels


def level_mazes(run: LoadedRun, n: int, split: str = "test") -> list:
    """``n`` layouts of the run's drawn worlds of ``split`` (its family's, or each
    world's share of a mix), each a maze whose first goal is its own, from one fixed
    key."""
    env, _ = from_config(run.config, prepare=False)
    if not env.generates:
        raise JaxnavError("levels need a run trained on drawn mazes (env.generator)")
    env = dataclasses.replace(env, split=split, maze_bank=n)
    bank = jax.jit(env.draw_bank)(jax.random.PRNGKey(LEVEL_SALT))
    maze, goal, _ = jax.tree.map(np.asarray, bank)
    return [
        jax.tree.map(lambda a, i=i: a[i], maze).replace(goal=goal[i])
        for i in range(min(n, goal.shape[0]))
    ]


def _fixed(policies: Policies) -> Policies:
    """The policies' environment with one fixed maze, its goal the maze's own first."""
    env = dataclasses.replace(
        policies.env, generator="", maze_bank=0, maze_bank_refresh=0, broad_phase="none"
    )
    return policies._replace(env=env)


def one_seat(policies: Policies) -> Policies:
    """``policies`` cut to their first run (a reference driver's one seat)."""
    return policies._replace(
        labels=policies.labels[:1],
        fields=policies.fields[:1],
        params=jax.tree.map(lambda a: np.asarray(a)[:1], policies.params),
        strategy=np.asarray(policies.strategy)[:1],
        hyper=jax.tree.map(lambda a: np.asarray(a)[:1], policies.hyper),
    )


def solved(policies: Policies, mazes: Sequence, say: Callable[[str], None] | None = None):
    """bool[levels, policies]: whether each policy's first goal attempt in each level
    reached its goal."""
    limit = policies.env.attempt_steps(policies.env_params)
    out = np.zeros((len(mazes), len(policies.labels)), bool)
    for i, maze in enumerate(mazes):
        if say is not None and i % 100 == 0:
            say(f"levels {i}-{min(i + 100, len(mazes)) - 1} of {len(mazes)}")
        res = run_tests(policies, [maze], 1, navigation=True)[0]
        for r in range(len(policies.labels)):
            att = run_attempts(res.steps, r, 1, limit)
            out[i, r] = len(att.outcome) > 0 and att.outcome[0] == SUCCESS
    return out


def summary(per_level: np.ndarray, rng: np.random.Generator) -> dict[str, float]:
    """Mean success over levels and over their worst tenth, each with a 95% bootstrap
    interval over levels (``per_level``: f[levels], a level's success)."""
    per_level = np.asarray(per_level, np.float64)
    k = max(1, int(round(WORST * len(per_level))))

    def worst(x):
        return float(np.mean(np.sort(x)[:k]))

    idx = rng.integers(0, len(per_level), size=(2000, len(per_level)))
    means = per_level[idx].mean(axis=1)
    worsts = np.asarray([worst(per_level[i]) for i in idx])
    return {
        "levels": len(per_level),
        "mean": float(per_level.mean()),
        "mean_lo": float(np.quantile(means, 0.025)),
        "mean_hi": float(np.quantile(means, 0.975)),
        "worst_tenth": worst(per_level),
        "worst_lo": float(np.quantile(worsts, 0.025)),
        "worst_hi": float(np.quantile(worsts, 0.975)),
    }


def level_test(
    run: LoadedRun,
    n: int,
    references: Sequence[str] = ("oracle",),
    say: Callable[[str], None] | None = None,
) -> list[dict]:
    """Every policy of ``run`` and each reference driver on ``n`` levels of the run's
    test split: per level, each driver's share of policies that solved it. Rows
    ``{"level", "driver", "policies", "solved"}``."""
    mazes = level_mazes(run, n)
    policies = _fixed(run.policies)
    drivers = {"policy": policies}
    for name in references:  # one seat each (see the module's note)
        drivers[name] = in_place_of(name, one_seat(policies), mazes[: min(len(mazes), BANK_BATCH)])
    rows = []
    for name, who in drivers.items():
        if say is not None:
            say(f"{name} on {len(mazes)} levels of the test split")
        got = solved(who, mazes, say)
        for i in range(len(mazes)):
            rows.append(
                {
                    "level": i,
                    "driver": name,
                    "policies": got.shape[1],
                    "solved": int(got[i].sum()),
                }
            )
    return rows


LEVEL_COLUMNS = ("level", "driver", "policies", "solved")


def levels_text(rows: Sequence[dict]) -> str:
    """Per driver, the mean success over the levels and over their worst tenth [95% CI]."""
    rng = np.random.default_rng(0)
    lines = []
    for driver in dict.fromkeys(r["driver"] for r in rows):
        mine = [r for r in rows if r["driver"] == driver]
        per = np.asarray([int(r["solved"]) / int(r["policies"]) for r in mine])
        s = summary(per, rng)
        lines.append(
            f"  {driver:<8} {s['levels']} levels: mean {s['mean']:.3f} "
            f"[{s['mean_lo']:.3f}, {s['mean_hi']:.3f}], worst tenth {s['worst_tenth']:.3f} "
            f"[{s['worst_lo']:.3f}, {s['worst_hi']:.3f}]"
        )
    return "\n".join(lines)


def levels_to_dir(
    run_dir: str | Path,
    n: int,
    out: str | Path,
    references: Sequence[str] = ("oracle",),
    say: Callable[[str], None] | None = None,
) -> Path:
    """:func:`level_test` of a finished run, written to ``out/levels.csv`` (atomically)."""
    run = load_run(run_dir)
    rows = level_test(run, n, references, say)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    text = rundir.csv_text(LEVEL_COLUMNS, [[r[c] for c in LEVEL_COLUMNS] for r in rows])
    rundir.atomic_write_text(out / "levels.csv", text)
    return out / "levels.csv"


__all__ = [
    "LEVEL_COLUMNS",
    "LEVEL_SALT",
    "WORST",
    "level_mazes",
    "level_test",
    "levels_text",
    "one_seat",
    "levels_to_dir",
    "solved",
    "summary",
]
