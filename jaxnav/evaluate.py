"""``python -m jaxnav.evaluate RUN_DIR [--mazes M ...] [--episodes N] [--out DIR] [--robustness]``

The paper's test protocol (Sec. 6, Tables 3 and 4): every trained policy runs N
consecutive greedy test episodes on each test maze and the tables report the mean
± std of the episode return.

* Greedy: dropout off, no exploration, action = argmax Q.
* Consecutive: the episodes follow one another in one environment; after a
  collision or truncation the robot restarts at the start pose and keeps its goal
  (the env's auto-reset), as in the paper's Gazebo runs.
* The training environment's settings (preset, n_beams, max_steps, reward
  constants, LiDAR noise, observation layout): only the maze changes. The network's
  input size depends on the layout, so a policy trained with the obstacle
  observation (min range, its beam) keeps it on every test maze.
* Every strategy and seed runs in one jitted, vmapped ``lax.scan`` per maze; all
  test mazes are padded to one shape (:func:`padded_mazes`), so the scan compiles
  once. Both strategies of a seed use the same test key.

Defaults are the run's ``run.test_mazes`` and ``run.test_episodes``; ``--mazes``
replaces the maze list (built-in names or maze YAML paths). Writes, atomically::

    RUN_DIR/eval/results.csv        strategy, seed, maze, episode, return, goals, collided, length
    RUN_DIR/eval/tables.md          paper-form tables, across-seed statistics, the paper's numbers
    RUN_DIR/eval/trajectories.npz   the first test episode of the config's seed, per strategy
                                    and maze, step by step (for jaxnav.plots)

The tables are a pure function of results.csv (:func:`tables_markdown`).

``--robustness`` runs the same test instead under each setting of
:data:`PERTURBATIONS` (range noise, beam dropout, odometry noise, random start
poses), each applied on top of the training environment's settings, on the
training maze (or ``--mazes``), and writes, atomically::

    RUN_DIR/eval/robustness.csv     strategy, seed, perturbation, maze, episode, return,
                                    goals, collided, length
    RUN_DIR/eval/robustness.md      per perturbation and strategy: mean return over seeds
                                    [95% CI], its change from the unperturbed row,
                                    goals per episode, collision rate
    RUN_DIR/eval/robustness.png     return per perturbation and strategy (jaxnav.plots)

The unperturbed setting (``none``) is the plain test: its rows equal results.csv's
for the same mazes and episodes.
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core
    from jaxnav.cpu import use_all_cores

    use_all_cores()

import argparse
import csv
import dataclasses
import functools
import io
import sys
import zipfile
from pathlib import Path
from typing import Any, NamedTuple, Sequence

import chex
import jax
import jax.numpy as jnp
import numpy as np

from jaxnav import stats
from jaxnav.sharding import RunSharding
from jaxnav.config import STRATEGIES, Config, ConfigError, load_config
from jaxnav.dqn import QNetwork, make_env
from jaxnav.env import EnvParams, NavEnv
from jaxnav.maps import MAX_GOAL_POINTS, Maze, MazeError, make_maze, pad_maze
from jaxnav.train import (
    RunError,
    _csv_text,
    atomic_write_bytes,
    atomic_write_text,
    load_params,
    run_labels,
)

RESULT_COLUMNS = ("strategy", "seed", "maze", "episode", "return", "goals", "collided", "length")
EVAL_SALT = 0x7E57  # folded into a seed's key: test goals differ from training's
STRATEGY_NAMES = {"ebe": "EBE", "epsilon_greedy": "epsilon-greedy"}

# Paper Tables 3 and 4 (mean ± std over 10 consecutive test episodes), keyed by the
# training maze, then our test maze -> (paper's row name, {strategy: (mean, std)}).
PAPER_TABLES: dict[str, tuple[str, dict[str, tuple[str, dict[str, tuple[float, float]]]]]] = {
    "square4": (
        "Table 3 (trained on the 4x4 square maze, no obstacles)",
        {
            "square4": (
                "4x4 Square",
                {"ebe": (3731.92, 368.35), "epsilon_greedy": (2202.93, 425.89)},
            ),
            "square8": (
                "8x8 Square",
                {"ebe": (2638.52, 319.07), "epsilon_greedy": (1662.57, 402.94)},
            ),
            "square2": (
                "2x2 Square",
                {"ebe": (4369.64, 935.56), "epsilon_greedy": (5556.55, 377.02)},
            ),
            "triangle": (
                "Triangle",
                {"ebe": (3655.37, 915.96), "epsilon_greedy": (1678.71, 1257.50)},
            ),
            "pentagon": (
                "Pentagon",
                {"ebe": (2794.04, 544.07), "epsilon_greedy": (2065.00, 882.77)},
            ),
        },
    ),
    "square4_obstacles": (
        "Table 4 (trained on the 4x4 square maze with obstacles)",
        {
            "square4_obstacles": (
                "4x4 Square",
                {"ebe": (1125.45, 775.82), "epsilon_greedy": (450.19, 760.14)},
            ),
            "pentagon_obstacles": (
                "Pentagon",
                {"ebe": (890.99, 641.19), "epsilon_greedy": (432.28, 210.37)},
            ),
        },
    ),
}


class EvalError(Exception):
    """A problem with the run or the request; the message is one line."""


# ----------------------------------------------------------------------------
# Rollout (pure, jitted)
# ----------------------------------------------------------------------------


class Trajectory(NamedTuple):
    """Per-step record of a rollout; the pose is the one *before* the step.

    Leading axes [..., T] (T = n_episodes * max_steps); steps after the last test
    episode have ``episode == n_episodes`` and are not part of the test.
    """

    pos: chex.Array  # f32[..., T, 2]
    yaw: chex.Array  # f32[..., T]
    goal: chex.Array  # f32[..., T, 2]
    ranges: chex.Array  # f32[..., T, n_beams] the scan the policy saw
    action: chex.Array  # i32[..., T]
    reward: chex.Array  # f32[..., T]
    reached: chex.Array  # bool[..., T] the goal was reached in this step
    collided: chex.Array  # bool[..., T] the robot collided in this step
    episode: chex.Array  # i32[..., T] test episode of this step


class Rollout(NamedTuple):
    """Per-episode test results [..., n_episodes] and, optionally, the trajectory."""

    ret: chex.Array  # f32[..., E]
    goals: chex.Array  # i32[..., E]
    collided: chex.Array  # bool[..., E]
    length: chex.Array  # i32[..., E]
    trajectory: Trajectory | None


def make_rollout(
    env: NavEnv, network: QNetwork, n_episodes: int, max_steps: int, record: bool = False
):
    """A pure ``rollout(params, key, env_params) -> Rollout`` of one greedy policy.

    Plays ``n_episodes`` consecutive episodes in one environment with auto-reset.
    Each episode lasts at most ``max_steps`` steps, so a scan of
    ``n_episodes * max_steps`` steps always completes them; later steps are ignored.
    """
    n_steps = n_episodes * max_steps
    E = n_episodes

    def rollout(params, key: chex.PRNGKey, env_params: EnvParams) -> Rollout:
        k_reset, key = jax.random.split(key)
        obs, state = env.reset(k_reset, env_params)
        zeros_f = jnp.zeros(E, jnp.float32)
        zeros_i = jnp.zeros(E, jnp.int32)
        carry0 = (
            obs,
            state,
            key,
            jnp.zeros((), jnp.int32),  # episode being played
            jnp.zeros((), jnp.float32),  # its return so far
            jnp.zeros((), jnp.int32),  # its goals so far
            (zeros_f, zeros_i, jnp.zeros(E, bool), zeros_i),
        )

        def body(carry, _):
            obs, state, key, ep, cur_ret, cur_goals, (rets, goals, coll, lens) = carry
            key, k_step = jax.random.split(key)
            # ACT: greedy, dropout off (Keras predict).
            q = network.apply(params, obs)
            action = jnp.argmax(q, axis=-1).astype(jnp.int32)
            # STEP ENV (auto-reset keeps the goal, restarts at the start pose).
            obs2, state2, reward, terminated, truncated, info = env.step(
                k_step, state, action, env_params
            )
            done = terminated | truncated
            cur_ret = cur_ret + reward
            cur_goals = cur_goals + info["goal_reached"].astype(jnp.int32)
            # RECORD the finished episode (index E: dropped, the test is over).
            i = jnp.where(done & (ep < E), ep, E)
            rets = rets.at[i].set(cur_ret, mode="drop")
            goals = goals.at[i].set(cur_goals, mode="drop")
            coll = coll.at[i].set(terminated, mode="drop")
            lens = lens.at[i].set(state.t + 1, mode="drop")
            out = None
            if record:
                out = Trajectory(
                    pos=state.pos,
                    yaw=state.yaw,
                    goal=state.goal,
                    ranges=obs[: env.n_beams],
                    action=action,
                    reward=reward,
                    reached=info["goal_reached"],
                    collided=terminated,
                    episode=ep,
                )
            carry = (
                obs2,
                state2,
                key,
                ep + done.astype(jnp.int32),
                jnp.where(done, 0.0, cur_ret),
                jnp.where(done, 0, cur_goals),
                (rets, goals, coll, lens),
            )
            return carry, out

        carry, traj = jax.lax.scan(body, carry0, None, length=n_steps)
        rets, goals, coll, lens = carry[-1]
        return Rollout(rets, goals, coll, lens, traj)

    return rollout


# ----------------------------------------------------------------------------
# Loading a run
# ----------------------------------------------------------------------------


class LoadedRun(NamedTuple):
    config: Config
    labels: list[tuple[str, int]]  # (strategy, seed) per run, the params' leading axis
    params: Any  # flax params, every leaf with a leading run axis
    env: NavEnv  # the training env (static settings)
    env_params: EnvParams  # the training env's params
    network: QNetwork


def load_run(run_dir: str | Path) -> LoadedRun:
    """Config and parameters of a finished training run (raises EvalError)."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise EvalError(f"run directory {run_dir} does not exist")
    cfg_path, params_path = run_dir / "config.yaml", run_dir / "params.npz"
    if not cfg_path.is_file():
        raise EvalError(f"{run_dir} is not a run directory (no config.yaml)")
    if not params_path.is_file():
        raise EvalError(f"{run_dir} has no params.npz (training has not finished; resume it first)")
    cfg = load_config(str(cfg_path))
    env, env_params = make_env(cfg)
    network = QNetwork(env.num_actions, tuple(cfg.dqn.hidden), cfg.dqn.dropout)
    template = network.init(jax.random.PRNGKey(0), jnp.zeros(env.obs_size))
    labels = run_labels(cfg)
    trees = []
    for strategy, seed in labels:
        try:
            tree = load_params(params_path, strategy, seed)
        except (OSError, ValueError, zipfile.BadZipFile, EOFError):
            raise EvalError(f"{params_path} cannot be read") from None
        except RunError as e:
            raise EvalError(str(e)) from None
        try:
            shapes_ok = jax.tree.structure(tree) == jax.tree.structure(template) and all(
                np.shape(a) == np.shape(b)
                for a, b in zip(jax.tree.leaves(tree), jax.tree.leaves(template))
            )
        except Exception:
            shapes_ok = False
        if not shapes_ok:
            raise EvalError(
                f"{params_path} does not match the network of {cfg_path} ({strategy} seed {seed})"
            )
        trees.append(tree)
    params = jax.tree.map(lambda *xs: jnp.asarray(np.stack(xs), jnp.float32), *trees)
    return LoadedRun(cfg, labels, params, env, env_params, network)


def padded_mazes(names: Sequence[str]) -> list[Maze]:
    """Mazes by name or YAML path, padded to one shape so one compile serves all.

    Goal points are padded to MAX_GOAL_POINTS (they are only indexed, so this costs
    nothing) and the shape then depends only on the largest wall and obstacle
    counts: most maze sets share a compiled rollout.
    """
    mazes = [make_maze(n) for n in names]
    s = max(m.segments.shape[0] for m in mazes)
    c = max(m.circles.shape[0] for m in mazes)
    g = max([MAX_GOAL_POINTS] + [m.goal_points.shape[0] for m in mazes])
    return [pad_maze(m, s, c, g) for m in mazes]


def eval_keys(labels: Sequence[tuple[str, int]]) -> chex.Array:
    """Test key per run: a seed's key with EVAL_SALT folded in (shared by strategies)."""
    return jnp.stack(
        [jax.random.fold_in(jax.random.PRNGKey(seed), EVAL_SALT) for _, seed in labels]
    )


@functools.lru_cache(maxsize=16)
def _compiled_rollout(
    env: NavEnv, network: QNetwork, n_episodes: int, max_steps: int, record: bool
):
    """jit(vmap(rollout)) over runs, one per setting: equal shapes never recompile."""
    rollout = make_rollout(env, network, n_episodes, max_steps, record)
    return jax.jit(jax.vmap(rollout, in_axes=(0, 0, None)))


def run_tests(
    run: LoadedRun,
    mazes: Sequence[Maze],
    n_episodes: int,
    select: Sequence[int] | None = None,
    record: bool = False,
) -> list[Rollout]:
    """One vmapped rollout of every (selected) run per maze; NumPy results."""
    idx = np.arange(len(run.labels)) if select is None else np.asarray(select)
    # The run axis is laid over every device, as in training.
    shard = RunSharding(len(idx))
    params = shard.put(jax.tree.map(lambda x: np.asarray(x)[idx], run.params))
    keys = shard.put(np.asarray(eval_keys([run.labels[i] for i in idx])))
    fn = _compiled_rollout(run.env, run.network, n_episodes, int(run.env_params.max_steps), record)
    out = []
    for maze in mazes:
        res = fn(params, keys, run.env_params.replace(maze=maze))
        out.append(shard.get(res))
    return out


def first_episode(res: Rollout, r: int) -> dict[str, Any]:
    """The first test episode of run r of a recorded Rollout, cut to its length."""
    n = int(res.length[r, 0])
    tr = res.trajectory
    return {
        "pos": tr.pos[r, :n],
        "yaw": tr.yaw[r, :n],
        "goal": tr.goal[r, :n],
        "ranges": tr.ranges[r, :n],
        "reward": tr.reward[r, :n],
        "reached": tr.reached[r, :n],
        "collided": bool(res.collided[r, 0]),
        "return": float(res.ret[r, 0]),
        "goals": int(res.goals[r, 0]),
        "length": n,
    }


Episodes = dict[str, dict[str, dict[str, Any]]]  # maze -> strategy -> first_episode()


def episodes_npz(episodes: Episodes, goal_radius: float) -> bytes:
    """trajectories.npz bytes: "<maze index>/<strategy>/<field>", the maze names and
    the goal radius (what a plot needs besides the maze)."""
    arrays: dict[str, np.ndarray] = {
        "mazes": np.asarray(list(episodes), dtype=str),
        "goal_radius": np.asarray(goal_radius, np.float64),
    }
    for i, per_strategy in enumerate(episodes.values()):
        for s, ep in per_strategy.items():
            for k, v in ep.items():
                arrays[f"{i}/{s}/{k}"] = np.asarray(v)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def read_episodes_npz(path: str | Path) -> tuple[Episodes, float]:
    """Inverse of :func:`episodes_npz`: (episodes, goal radius)."""
    with np.load(path, allow_pickle=False) as data:
        names = [str(m) for m in data["mazes"]]
        goal_radius = float(data["goal_radius"])
        out: Episodes = {m: {} for m in names}
        for key in data.files:
            if key in ("mazes", "goal_radius"):
                continue
            i, s, k = key.split("/")
            v = data[key]
            out[names[int(i)]].setdefault(s, {})[k] = v if v.ndim else v.item()
    return out, goal_radius


def evaluate(
    run_dir: str | Path, maze_names: Sequence[str] | None = None, n_episodes: int | None = None
) -> tuple[LoadedRun, list[str], str, Episodes]:
    """Test every run of ``run_dir``.

    Returns (run, maze names, results.csv text, the first test episode of the
    config's seed per maze and strategy).
    """
    run = load_run(run_dir)
    names = list(maze_names) if maze_names else list(run.config.run.test_mazes)
    if len(set(names)) != len(names):
        raise EvalError("a maze is listed twice")
    n_episodes = run.config.run.test_episodes if n_episodes is None else n_episodes
    if n_episodes < 1:
        raise EvalError("--episodes must be at least 1")
    mazes = padded_mazes(names)
    results = run_tests(run, mazes, n_episodes, record=True)
    first = [i for i, (_, seed) in enumerate(run.labels) if seed == run.config.seed]
    episodes = {
        name: {run.labels[i][0]: first_episode(res, i) for i in first}
        for name, res in zip(names, results)
    }
    rows = list(_episode_rows(run.labels, names, results, n_episodes))
    return run, names, _csv_text(RESULT_COLUMNS, rows), episodes


def _episode_rows(labels, names, results, n_episodes, perturbation: str | None = None):
    """CSV rows (strategy, seed[, perturbation], maze, episode, return, goals, collided,
    length) of run_tests() results."""
    tag = () if perturbation is None else (perturbation,)
    for name, res in zip(names, results):
        for r, (strategy, seed) in enumerate(labels):
            for e in range(n_episodes):
                yield (
                    strategy,
                    seed,
                    *tag,
                    name,
                    e,
                    f"{float(res.ret[r, e]):.4f}",
                    int(res.goals[r, e]),
                    int(res.collided[r, e]),
                    int(res.length[r, e]),
                )


# ----------------------------------------------------------------------------
# Tables (pure functions of results.csv)
# ----------------------------------------------------------------------------


def read_results(text: str) -> dict[tuple[str, str, int], dict[str, np.ndarray]]:
    """results.csv text -> {(maze, strategy, seed): {column: per-episode array}}."""
    return _read_episodes(text, ("maze", "strategy", "seed"))


def _read_episodes(text: str, key_columns: Sequence[str]) -> dict[tuple, dict[str, np.ndarray]]:
    """Episode rows -> {key (seed as int): {column: per-episode array, by episode}}."""
    out: dict[tuple, dict[str, list]] = {}
    for row in csv.DictReader(io.StringIO(text)):
        key = tuple(int(row[c]) if c == "seed" else row[c] for c in key_columns)
        d = out.setdefault(
            key, {"episode": [], "return": [], "goals": [], "collided": [], "length": []}
        )
        for c in d:
            d[c].append(float(row[c]))
    res = {}
    for key, d in out.items():
        order = np.argsort(d["episode"])
        res[key] = {c: np.asarray(v)[order] for c, v in d.items()}
    return res


def _ordered_unique(xs):
    seen = []
    for x in xs:
        if x not in seen:
            seen.append(x)
    return seen


def _pm(mean: float, std: float) -> str:
    return f"{mean:.2f} ± {std:.2f}"


def _ci(iv: stats.Interval, digits: int = 1) -> str:
    if np.isnan(iv.low):
        return f"{iv.value:.{digits}f} [n/a]"
    return f"{iv.value:.{digits}f} [{iv.low:.{digits}f}, {iv.high:.{digits}f}]"


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return lines


def per_seed_scores(
    results, maze: str, strategy: str, seeds: Sequence[int], column: str = "return"
) -> np.ndarray:
    """Per-seed mean of a column over the test episodes -> f[len(seeds)]."""
    return np.asarray([results[(maze, strategy, s)][column].mean() for s in seeds])


def tables_markdown(
    results_csv: str, train_maze: str, first_seed: int, title: str = "Test results"
) -> str:
    """The report's tables from results.csv text.

    Args:
      results_csv: the text of results.csv.
      train_maze: the training maze (picks the paper's Table 3 or 4).
      first_seed: the config's seed: the single-seed table uses it, as the paper
        shows one run.
    """
    results = read_results(results_csv)
    if not results:
        raise EvalError("results.csv has no rows")
    mazes = _ordered_unique(k[0] for k in results)
    strategies = [s for s in STRATEGIES if any(k[1] == s for k in results)]
    seeds = sorted({k[2] for k in results})
    n_eps = {len(v["return"]) for v in results.values()}
    names = [STRATEGY_NAMES[s] for s in strategies]
    seed0 = first_seed if first_seed in seeds else seeds[0]
    L: list[str] = [f"# {title}", ""]
    L += [
        f"Trained on `{train_maze}`; {len(seeds)} seed(s) per strategy; "
        f"{'/'.join(map(str, sorted(n_eps)))} consecutive greedy test episodes per seed and maze "
        "(dropout off, argmax Q, the training environment's settings).",
        "",
        f"## Paper form: mean ± std (ddof 0) of the episode return over the test episodes, seed {seed0}",
        "",
    ]
    L += _table(
        ["maze"] + names,
        [
            [m] + [_pm(*stats.mean_std(results[(m, s, seed0)]["return"])) for s in strategies]
            for m in mazes
        ],
    )
    L += ["", "## Paper form, every seed", ""]
    L += _table(
        ["maze", "seed"] + names,
        [
            [m, str(k)] + [_pm(*stats.mean_std(results[(m, s, k)]["return"])) for s in strategies]
            for m in mazes
            for k in seeds
        ],
    )

    L += [
        "",
        "## Across seeds",
        "",
        "A seed's score is its mean return over the test episodes. Mean and IQM "
        "(interquartile mean, scipy `trim_mean(x, 0.25)`) of the per-seed scores, with "
        f"{int(stats.CONFIDENCE * 100)}% percentile-bootstrap confidence intervals over seeds "
        f"({stats.N_RESAMPLES} resamples; n/a with one seed; with a handful of seeds the interval "
        "is little more than the range of the per-seed scores). Goals per episode and the "
        "collision rate (share of test episodes that ended in a collision) pool all seeds.",
        "",
    ]
    rows = []
    for m in mazes:
        for s in strategies:
            x = per_seed_scores(results, m, s, seeds)
            goals = np.concatenate([results[(m, s, k)]["goals"] for k in seeds])
            coll = np.concatenate([results[(m, s, k)]["collided"] for k in seeds])
            rows.append(
                [
                    m,
                    STRATEGY_NAMES[s],
                    _ci(stats.mean_ci(x)),
                    _ci(stats.iqm_ci(x)),
                    f"{goals.mean():.2f}",
                    f"{coll.mean():.2f}",
                ]
            )
    L += _table(
        ["maze", "strategy", "mean [95% CI]", "IQM [95% CI]", "goals / episode", "collision rate"],
        rows,
    )

    if set(strategies) == set(STRATEGIES):
        L += [
            "",
            "## Probability of improvement",
            "",
            "P(EBE > epsilon-greedy) as rliable defines it: the chance that a seed of EBE "
            "scores more than a seed of epsilon-greedy, ties counting half "
            "(P(X > Y) + 0.5 P(X = Y) over all pairs of per-seed scores), with a stratified "
            "bootstrap CI (the seeds of each strategy resampled independently within each "
            "maze). 0.5: no difference. The last row averages over the mazes.",
            "",
        ]
        prow = []
        xs, ys = [], []
        for m in mazes:
            x = per_seed_scores(results, m, "ebe", seeds)
            y = per_seed_scores(results, m, "epsilon_greedy", seeds)
            xs.append(x)
            ys.append(y)
            prow.append([m, _ci(stats.probability_of_improvement_ci(x, y), 2)])
        if len(mazes) > 1:
            prow.append(
                [
                    "all mazes",
                    _ci(stats.probability_of_improvement_ci(np.stack(xs, 1), np.stack(ys, 1)), 2),
                ]
            )
        L += _table(["maze", "P(EBE > epsilon-greedy) [95% CI]"], prow)

    paper = PAPER_TABLES.get(train_maze)
    L += ["", "## Beside the paper", ""]
    rows = []
    if paper is not None:
        caption, table = paper
        for m in mazes:
            if m not in table:
                continue
            row_name, vals = table[m]
            row = [m, row_name]
            for s in strategies:
                row += [
                    _pm(*vals[s]),
                    _pm(*stats.mean_std(results[(m, s, seed0)]["return"])),
                    _ci(stats.mean_ci(per_seed_scores(results, m, s, seeds))),
                ]
            rows.append(row)
    if rows:
        L += [
            f"The paper's {caption}: mean ± std over 10 consecutive test episodes of its "
            f"single training run. Ours: seed {seed0} in the same form, and the mean over "
            "seeds of the per-seed mean return [95% bootstrap CI].",
            "",
        ]
        header = ["maze", "paper row"]
        for n in names:
            header += [f"{n} paper", f"{n} ours, seed {seed0}", f"{n} ours, all seeds"]
        L += _table(header, rows)
    else:
        L += [
            f"The paper reports no test results for these mazes after training on `{train_maze}`."
        ]
    return "\n".join(L) + "\n"


# ----------------------------------------------------------------------------
# Robustness: the same test under sensor and start-pose perturbations
# ----------------------------------------------------------------------------

ROBUSTNESS_COLUMNS = (
    "strategy",
    "seed",
    "perturbation",
    "maze",
    "episode",
    "return",
    "goals",
    "collided",
    "length",
)
UNPERTURBED = "none"

# The sweep: name -> settings that replace the training environment's; every other
# setting keeps its training value. A key is an EnvParams field (data: the compiled
# rollout is reused) or a NavEnv field (static: one compile per setting). Add a row
# to extend the sweep; the first row is the reference the others are compared with.
PERTURBATIONS: dict[str, dict[str, Any]] = {
    UNPERTURBED: {},
    "range_noise_0.02": {"lidar_noise_std": 0.02},
    "range_noise_0.05": {"lidar_noise_std": 0.05},
    "range_noise_0.1": {"lidar_noise_std": 0.1},
    "beam_dropout_0.05": {"beam_dropout": 0.05},
    "beam_dropout_0.2": {"beam_dropout": 0.2},
    "odom_noise_0.05": {"odom_noise": (0.05, 0.05)},
    "random_start": {"random_start": True},
}

# The realism settings of a training environment, shown beside the sweep.
REALISM_SETTINGS = ("lidar_noise_std", "beam_dropout", "odom_noise", "random_start", "maze_scale")

_PARAM_FIELDS = {f.name for f in dataclasses.fields(EnvParams)} - {"maze"}
_ENV_FIELDS = {f.name for f in dataclasses.fields(NavEnv)}


def perturb(
    env: NavEnv, env_params: EnvParams, overrides: dict[str, Any]
) -> tuple[NavEnv, EnvParams]:
    """The environment with ``overrides`` replacing its settings (raises EvalError).

    The observation must keep its size: the policy's network is fixed.
    """
    unknown = sorted(set(overrides) - _PARAM_FIELDS - _ENV_FIELDS)
    if unknown:
        raise EvalError(f"unknown environment setting '{unknown[0]}' in a perturbation")
    static = {k: v for k, v in overrides.items() if k in _ENV_FIELDS}
    data = {k: v for k, v in overrides.items() if k in _PARAM_FIELDS}
    try:
        new_env = dataclasses.replace(env, **static)
    except (TypeError, ValueError) as e:
        raise EvalError(f"perturbation {overrides}: {e}") from None
    if new_env.obs_size != env.obs_size:
        raise EvalError(f"perturbation {overrides} changes the observation size")
    return new_env, env_params.replace(**data)


def realism_settings(env: NavEnv, env_params: EnvParams) -> dict[str, Any]:
    """The sensor and start-pose settings of an environment (:data:`REALISM_SETTINGS`)."""
    return {
        k: getattr(env_params if k in _PARAM_FIELDS else env, k) for k in REALISM_SETTINGS
    }


def robustness(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    perturbations: dict[str, dict[str, Any]] = PERTURBATIONS,
) -> tuple[LoadedRun, list[str], str]:
    """Test every run of ``run_dir`` under each perturbation of the training env.

    The plain test (:func:`evaluate`'s rollout, keys and episodes) with the env's
    settings replaced; defaults: the training maze, ``run.test_episodes``.
    Returns (run, maze names, robustness.csv text).
    """
    run = load_run(run_dir)
    names = list(maze_names) if maze_names else [run.config.env.maze]
    if len(set(names)) != len(names):
        raise EvalError("a maze is listed twice")
    n_episodes = run.config.run.test_episodes if n_episodes is None else n_episodes
    if n_episodes < 1:
        raise EvalError("--episodes must be at least 1")
    if not perturbations:
        raise EvalError("no perturbations to test")
    settings = {p: perturb(run.env, run.env_params, ov) for p, ov in perturbations.items()}
    mazes = padded_mazes(names)
    rows = []
    for p, (env, env_params) in settings.items():
        # record=True: the same program as evaluate()'s, so "none" repeats it exactly.
        results = run_tests(run._replace(env=env, env_params=env_params), mazes, n_episodes, record=True)
        rows += _episode_rows(run.labels, names, results, n_episodes, perturbation=p)
    return run, names, _csv_text(ROBUSTNESS_COLUMNS, rows)


def read_robustness(text: str) -> dict[tuple[str, str, str, int], dict[str, np.ndarray]]:
    """robustness.csv text -> {(perturbation, maze, strategy, seed): {column: per-episode array}}."""
    return _read_episodes(text, ("perturbation", "maze", "strategy", "seed"))


class RobustnessRow(NamedTuple):
    """One (maze, perturbation, strategy) line of the robustness table."""

    maze: str
    perturbation: str
    strategy: str
    n_seeds: int
    mean: stats.Interval  # mean over seeds of the per-seed mean return
    change: stats.Interval | None  # mean over seeds of (perturbed - unperturbed) score
    change_pct: float  # change / |unperturbed mean| in %, NaN if undefined
    goals: float  # goals per episode, all seeds pooled
    collision_rate: float  # share of episodes that ended in a collision


def _by_seed(res, perturbation: str, maze: str, strategy: str) -> dict[int, dict[str, np.ndarray]]:
    return {k[3]: v for k, v in res.items() if k[:3] == (perturbation, maze, strategy)}


def robustness_summary(text: str) -> list[RobustnessRow]:
    """The robustness table's numbers from robustness.csv text.

    A seed's score is its mean return over the test episodes; the change is paired
    by seed (same seed, same test key) against the unperturbed setting.
    """
    res = read_robustness(text)
    if not res:
        raise EvalError("robustness.csv has no rows")
    perts = _ordered_unique(k[0] for k in res)
    mazes = _ordered_unique(k[1] for k in res)
    strategies = [s for s in STRATEGIES if any(k[2] == s for k in res)]
    out = []
    for m in mazes:
        for s in strategies:
            ref = {k: v["return"].mean() for k, v in _by_seed(res, UNPERTURBED, m, s).items()}
            for p in perts:
                eps = _by_seed(res, p, m, s)
                if not eps:
                    continue
                seeds = sorted(eps)
                x = np.asarray([eps[k]["return"].mean() for k in seeds])
                change, pct = None, float("nan")
                if p != UNPERTURBED and ref and set(seeds) <= set(ref):
                    b = np.asarray([ref[k] for k in seeds])
                    change = stats.mean_ci(x - b)
                    if b.mean() != 0:
                        pct = 100.0 * change.value / abs(b.mean())
                goals = np.concatenate([eps[k]["goals"] for k in seeds])
                coll = np.concatenate([eps[k]["collided"] for k in seeds])
                out.append(
                    RobustnessRow(
                        maze=m,
                        perturbation=p,
                        strategy=s,
                        n_seeds=len(seeds),
                        mean=stats.mean_ci(x),
                        change=change,
                        change_pct=pct,
                        goals=float(goals.mean()),
                        collision_rate=float(coll.mean()),
                    )
                )
    # Perturbation by perturbation, the strategies side by side.
    rank = {p: i for i, p in enumerate(perts)}
    out.sort(key=lambda r: (mazes.index(r.maze), rank[r.perturbation], strategies.index(r.strategy)))
    return out


def _signed_ci(iv: stats.Interval, digits: int = 1) -> str:
    if np.isnan(iv.low):
        return f"{iv.value:+.{digits}f} [n/a]"
    return f"{iv.value:+.{digits}f} [{iv.low:+.{digits}f}, {iv.high:+.{digits}f}]"


def _setting_text(overrides: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in overrides.items())


def robustness_markdown(
    robustness_csv: str,
    train_maze: str,
    training: dict[str, Any],
    perturbations: dict[str, dict[str, Any]] = PERTURBATIONS,
    title: str = "Robustness",
    figure: str | None = None,
) -> str:
    """robustness.md from robustness.csv text.

    Args:
      robustness_csv: the text of robustness.csv.
      train_maze: the training maze.
      training: the training env's realism settings (:func:`realism_settings`).
      perturbations: the sweep, for the setting column (names not in it show none).
      figure: a link to robustness.png to show under the introduction, if given.
    """
    rows = robustness_summary(robustness_csv)
    res = read_robustness(robustness_csv)
    seeds = sorted({k[3] for k in res})
    n_eps = sorted({len(v["return"]) for v in res.values()})
    mazes = _ordered_unique(r.maze for r in rows)
    L = [f"# {title}", ""]
    L += [
        f"Trained on `{train_maze}` with {_setting_text(training)}. Every policy plays the "
        f"plain test ({'/'.join(map(str, n_eps))} consecutive greedy episodes per seed, the "
        "same test keys) under each perturbation: the named setting replaces the training "
        "environment's, every other setting stays as trained, and `none` is the plain test.",
        "",
        f"A seed's score is its mean return. Mean over {len(seeds)} seed(s) with a "
        f"{int(stats.CONFIDENCE * 100)}% percentile-bootstrap CI; change: the mean over seeds "
        "of each seed's score minus its unperturbed score (paired by seed) with its CI, and "
        "in % of the unperturbed mean; goals per episode and the collision rate pool all "
        "seeds and episodes.",
        "",
    ]
    if figure:
        L += [f"![return under each perturbation]({figure})", ""]
    for m in mazes:
        if len(mazes) > 1:
            L += [f"## {m}", ""]
        table = []
        for r in (r for r in rows if r.maze == m):
            setting = (
                "as trained"
                if r.perturbation == UNPERTURBED
                else _setting_text(perturbations.get(r.perturbation, {}))
            )
            table.append(
                [
                    r.perturbation,
                    setting,
                    STRATEGY_NAMES[r.strategy],
                    _ci(r.mean),
                    "" if r.change is None else _signed_ci(r.change),
                    "" if np.isnan(r.change_pct) else f"{r.change_pct:+.0f}%",
                    f"{r.goals:.2f}",
                    f"{r.collision_rate:.2f}",
                ]
            )
        L += _table(
            [
                "perturbation",
                "setting",
                "strategy",
                "mean return [95% CI]",
                "change [95% CI]",
                "change %",
                "goals / episode",
                "collision rate",
            ],
            table,
        )
        L += [""]
    return "\n".join(L)


# ----------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------


def evaluate_to_dir(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    out: str | Path | None = None,
) -> Path:
    """Evaluate; write results.csv, tables.md, trajectories.npz (each atomically) into ``out``."""
    run, names, text, episodes = evaluate(run_dir, maze_names, n_episodes)
    tables = tables_markdown(
        text, run.config.env.maze, run.config.seed, title=f"Test results of {Path(run_dir).name}"
    )
    out = Path(out) if out is not None else Path(run_dir) / "eval"
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "results.csv", text)
    atomic_write_text(out / "tables.md", tables)
    atomic_write_bytes(
        out / "trajectories.npz", episodes_npz(episodes, float(run.env_params.goal_radius))
    )
    return out


def robustness_to_dir(
    run_dir: str | Path,
    maze_names: Sequence[str] | None = None,
    n_episodes: int | None = None,
    out: str | Path | None = None,
    perturbations: dict[str, dict[str, Any]] = PERTURBATIONS,
) -> Path:
    """The robustness sweep; write robustness.csv, .md and .png (each atomically) into ``out``."""
    from jaxnav import plots  # plots imports this module

    run, _, text = robustness(run_dir, maze_names, n_episodes, perturbations)
    name = Path(run_dir).name
    md = robustness_markdown(
        text,
        run.config.env.maze,
        realism_settings(run.env, run.env_params),
        perturbations,
        title=f"Robustness of {name} to sensor noise",
        figure="robustness.png",
    )
    out = Path(out) if out is not None else Path(run_dir) / "eval"
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "robustness.csv", text)
    atomic_write_text(out / "robustness.md", md)
    plots.plot_robustness(text, out / "robustness.png", title=f"{name}: return under perturbations")
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m jaxnav.evaluate",
        description="Test every trained policy of a run on the test mazes (the paper's "
        "protocol: N consecutive greedy episodes) and write eval/results.csv and eval/tables.md; "
        "with --robustness, test them under sensor perturbations instead.",
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished training run (with params.npz)")
    p.add_argument(
        "--mazes",
        nargs="+",
        metavar="M",
        help="test mazes, replacing the config's run.test_mazes (with --robustness: the "
        "training maze): built-in names (square2, square4, ...) or maze YAML paths",
    )
    p.add_argument(
        "--episodes",
        type=int,
        metavar="N",
        help="consecutive test episodes per seed (default run.test_episodes)",
    )
    p.add_argument("--out", metavar="DIR", help="output directory (default RUN_DIR/eval)")
    p.add_argument(
        "--robustness",
        action="store_true",
        help="instead of the plain test, play it under each perturbation of the training "
        "environment: "
        + "; ".join(
            f"{k} ({_setting_text(v)})" if v else f"{k} (as trained)"
            for k, v in PERTURBATIONS.items()
        )
        + ". Each replaces that setting only. Mazes default to the training maze. Writes "
        "robustness.csv, robustness.md (mean return over seeds with 95%% CI, its change "
        "from 'none', goals, collision rate) and robustness.png",
    )
    args = p.parse_args(argv)
    try:
        if args.robustness:
            out = robustness_to_dir(args.run_dir, args.mazes, args.episodes, args.out)
        else:
            out = evaluate_to_dir(args.run_dir, args.mazes, args.episodes, args.out)
    except (EvalError, ConfigError, MazeError, RunError) as e:
        print(f"jaxnav.evaluate: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(
            f"jaxnav.evaluate: error: {e.strerror or e}: {e.filename or ''}".rstrip(": "),
            file=sys.stderr,
        )
        return 2
    if args.robustness:
        print(
            f"wrote {out / 'robustness.csv'}, {out / 'robustness.md'} and {out / 'robustness.png'}"
        )
    else:
        print(f"wrote {out / 'results.csv'}, {out / 'tables.md'} and {out / 'trajectories.npz'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
