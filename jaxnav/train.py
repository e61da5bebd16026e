"""``python -m jaxnav.train CONFIG [key=value ...] [--out RUN_DIR] [--resume RUN_DIR]``

Trains every seed of every strategy in the config in one compiled program, run in
chunks of ``run.chunk_steps`` environment steps. After each chunk the host writes
the new per-episode metrics and a checkpoint, each atomically, so a run killed at
any moment (even by SIGKILL) resumes from its last chunk with ``--resume`` and
finishes with exactly the metrics and parameters of an uninterrupted run.

Run directory::

    config.yaml          the resolved config (every field)
    metrics.csv          strategy, seed, episode, return, length, goals, collided, explore
    explore.csv          strategy, seed, step, explore: mean EBE entropy H or epsilon
                         over blocks of 100 env steps
    checkpoints/last.npz full training state of the last finished chunk
    params.npz           final Q-network parameters, "<strategy>/seed<k>/<layer>/<name>"
    summary.json         wall-clock, steps, steps/s, last-50-episode means
"""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core
    from jaxnav.cpu import use_all_cores

    use_all_cores()

import argparse
import csv
import io
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxnav.config import STRATEGIES, Config, ConfigError, dump_config, load_config
from jaxnav.dqn import TrainState, buffer_bytes, make_trainer, run_keys
from jaxnav.maps import MazeError
from jaxnav.sharding import RunSharding, initialize, is_writer

METRIC_COLUMNS = ("strategy", "seed", "episode", "return", "length", "goals", "collided", "explore")
EXPLORE_BLOCK = 100  # env steps averaged per row of explore.csv
CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"


class RunError(Exception):
    """A problem with a run directory; one-line message."""


# ----------------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------------


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write a whole file or nothing (temp file, fsync, rename); process 0 only."""
    if not is_writer():
        return
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def _csv_text(header, rows) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    return buf.getvalue()


def resolve_config_path(name: str) -> str:
    """A config path, or a bare name of a file in the project's configs/."""
    if os.path.exists(name):
        return name
    for cand in (CONFIG_DIR / name, CONFIG_DIR / f"{name}.yaml"):
        if cand.is_file():
            return str(cand)
    return name  # load_config reports it missing


# ----------------------------------------------------------------------------
# Checkpoints
# ----------------------------------------------------------------------------

_BUFFER_ROWS = ("obs", "action", "reward", "terminated", "truncated", "final_index")


def _leaf_names(tree) -> list[str]:
    paths, _ = jax.tree_util.tree_flatten_with_path(tree)
    return [jax.tree_util.keystr(p) for p, _ in paths]


def save_checkpoint(path: Path, ts: TrainState, host: dict[str, np.ndarray]) -> None:
    """Training state as host arrays (buffers trimmed to their filled rows) plus host tables."""
    size = int(np.max(np.asarray(ts.buffer.size)))
    arrays: dict[str, np.ndarray] = {}
    for name, leaf in zip(_leaf_names(ts), jax.tree.leaves(ts)):
        a = np.asarray(leaf)
        if any(name == f".buffer.{r}" for r in _BUFFER_ROWS):
            a = a[:, :size]
        arrays["state" + name] = a
    for k, v in host.items():
        arrays["host." + k] = v
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: Path, template: TrainState) -> tuple[TrainState, dict[str, np.ndarray]]:
    try:
        data = np.load(path, allow_pickle=False)
        arrays = {k: data[k] for k in data.files}
    except Exception as e:  # a damaged file: say so in one line
        raise RunError(f"checkpoint {path} cannot be read ({type(e).__name__})") from None
    leaves = []
    for name, leaf in zip(_leaf_names(template), jax.tree.leaves(template)):
        key = "state" + name
        if key not in arrays:
            raise RunError(f"checkpoint {path} does not match the run's config (missing {name})")
        a = arrays[key]
        if a.shape != leaf.shape:
            if any(name == f".buffer.{r}" for r in _BUFFER_ROWS) and a.shape[1] <= leaf.shape[1]:
                full = np.zeros(leaf.shape, leaf.dtype)
                full[:, : a.shape[1]] = a
                a = full
            else:
                raise RunError(f"checkpoint {path} does not match the run's config ({name})")
        leaves.append(np.asarray(a, leaf.dtype))
    ts = jax.tree.unflatten(jax.tree.structure(template), leaves)
    host = {k[5:]: v for k, v in arrays.items() if k.startswith("host.")}
    return ts, host


# ----------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------


def run_labels(cfg: Config) -> list[tuple[str, int]]:
    """(strategy, seed) of each run, in the order of :func:`jaxnav.dqn.run_keys`."""
    return [(s, cfg.seed + i) for s in cfg.strategies for i in range(cfg.seeds)]


def save_params(path: Path, cfg: Config, params) -> None:
    """Portable (NumPy .npz, no pickle) parameters, one entry per run and array."""
    arrays = {}
    flat, _ = jax.tree_util.tree_flatten_with_path(params)
    for r, (strategy, seed) in enumerate(run_labels(cfg)):
        for p, leaf in flat:
            name = "/".join(str(getattr(k, "key", k)) for k in p)
            arrays[f"{strategy}/seed{seed}/{name}"] = np.asarray(leaf[r])
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def load_params(path: str | Path, strategy: str, seed: int):
    """Flax params of one run from a ``params.npz`` (NumPy arrays)."""
    prefix = f"{strategy}/seed{seed}/"
    try:
        data = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise RunError(f"{path} does not exist") from None
    except Exception as e:  # not an npz, truncated, ...
        raise RunError(f"{path} cannot be read ({type(e).__name__})") from None
    with data:
        tree: dict[str, Any] = {}
        found = False
        for k in data.files:
            if not k.startswith(prefix):
                continue
            found = True
            node = tree
            parts = k[len(prefix) :].split("/")
            for part in parts[:-1]:
                node = node.setdefault(part, {})
            node[parts[-1]] = np.asarray(data[k])
    if not found:
        raise RunError(f"{path} has no parameters for {strategy} seed {seed}")
    return tree


# ----------------------------------------------------------------------------
# The run
# ----------------------------------------------------------------------------


class Run:
    """Host loop around the compiled chunk: progress, metrics, checkpoints."""

    def __init__(self, cfg: Config, out: Path | None, quiet: bool = False):
        self.cfg, self.out, self.quiet = cfg, out, quiet
        self.trainer = make_trainer(cfg)
        self.labels = run_labels(cfg)
        # The run axis of every array is laid over all devices.
        self.shard = RunSharding(cfg.n_runs)
        out = self.shard.sharding
        self.init = jax.jit(jax.vmap(self.trainer.init), out_shardings=out)
        self.chunk = jax.jit(jax.vmap(self.trainer.chunk), donate_argnums=0, out_shardings=out)
        self.rows: list[tuple] = []
        self.explore_rows: list[tuple] = []
        self.logged = np.zeros(cfg.n_runs, np.int64)  # episodes written per run
        self.wall = 0.0  # training seconds over all sessions of this run

    # -- state ---------------------------------------------------------------

    def fresh_state(self) -> TrainState:
        keys, strat = self.shard.put(jax.tree.map(np.asarray, run_keys(self.cfg)))
        return self.init(keys, strat)

    def active(self, ts: TrainState) -> np.ndarray:
        """Which real runs still train (host side)."""
        episode, step = self.shard.get((ts.episode, ts.step))
        limit_e = self.cfg.episodes if self.cfg.episodes is not None else np.inf
        limit_s = self.cfg.total_steps if self.cfg.total_steps is not None else np.inf
        return (episode < limit_e) & (step < limit_s)

    def host_tables(self) -> dict[str, np.ndarray]:
        rows = np.asarray(self.rows, np.float64).reshape(-1, len(METRIC_COLUMNS))
        ex = np.asarray(self.explore_rows, np.float64).reshape(-1, 4)
        return {"metrics": rows, "explore": ex, "logged": self.logged, "wall": np.float64(self.wall)}

    def restore_host(self, host: dict[str, np.ndarray]) -> None:
        self.rows = [tuple(r) for r in host["metrics"].tolist()]
        self.explore_rows = [tuple(r) for r in host["explore"].tolist()]
        self.logged = host["logged"].astype(np.int64)
        self.wall = float(host["wall"])

    # -- per chunk -----------------------------------------------------------

    def collect(self, ts: TrainState, explore: np.ndarray, step_before: np.ndarray) -> None:
        m, episodes = self.shard.get((ts.metrics, ts.episode))
        slots = self.trainer.metric_slots
        for r in range(self.cfg.n_runs):
            s_idx = STRATEGIES.index(self.labels[r][0])
            for e in range(self.logged[r], episodes[r]):
                i = e % slots
                self.rows.append(
                    (
                        s_idx,
                        self.labels[r][1],
                        e,
                        float(m.ep_return[r, i]),
                        int(m.ep_length[r, i]),
                        int(m.ep_goals[r, i]),
                        int(m.ep_collided[r, i]),
                        float(m.ep_explore[r, i]),
                    )
                )
            self.logged[r] = episodes[r]
        # explore: [n_runs, chunk_steps], NaN once a run has finished.
        n = explore.shape[1]
        for r in range(self.cfg.n_runs):
            s_idx = STRATEGIES.index(self.labels[r][0])
            col = explore[r]
            for b in range(0, n, EXPLORE_BLOCK):
                block = col[b : b + EXPLORE_BLOCK]
                block = block[~np.isnan(block)]
                if len(block):
                    self.explore_rows.append(
                        (s_idx, self.labels[r][1], int(step_before[r]) + b, float(block.mean()))
                    )

    def write_tables(self) -> None:
        def fmt(r):
            return (
                STRATEGIES[int(r[0])],
                int(r[1]),
                int(r[2]),
                f"{r[3]:.6g}",
                int(r[4]),
                int(r[5]),
                int(r[6]),
                f"{r[7]:.6g}",
            )

        atomic_write_text(self.out / "metrics.csv", _csv_text(METRIC_COLUMNS, map(fmt, self.rows)))
        ex = ((STRATEGIES[int(a)], int(b), int(c), f"{d:.6g}") for a, b, c, d in self.explore_rows)
        atomic_write_text(self.out / "explore.csv", _csv_text(("strategy", "seed", "step", "explore"), ex))

    def progress_text(self, steps_per_s: float) -> str:
        parts = []
        for s in self.cfg.strategies:
            s_idx = STRATEGIES.index(s)
            recent: list[float] = []
            for r, (strategy, seed) in enumerate(self.labels):
                if strategy != s:
                    continue
                mine = [row[3] for row in self.rows if row[0] == s_idx and row[1] == seed]
                recent += mine[-20:]
            if recent:
                parts.append(f"{s} R={np.mean(recent):.0f}")
        parts.append(f"{steps_per_s / 1000:.1f}k steps/s")
        return " ".join(parts)

    # -- loop ----------------------------------------------------------------

    def train(self, ts: TrainState) -> TrainState:
        from tqdm import tqdm

        cfg = self.cfg
        ckpt = self.out / "checkpoints" / "last.npz"
        ckpt.parent.mkdir(parents=True, exist_ok=True)
        if cfg.episodes is not None:
            total, unit = cfg.n_runs * cfg.episodes, "ep"
            done_now = lambda t: int(np.minimum(self.shard.get(t.episode), cfg.episodes).sum())  # noqa: E731
        else:
            total, unit = cfg.n_runs * cfg.total_steps, "step"
            done_now = lambda t: int(self.shard.get(t.step).sum())  # noqa: E731
        bar = tqdm(
            total=total,
            initial=done_now(ts),
            unit=unit,
            disable=self.quiet or not is_writer(),
            dynamic_ncols=True,
            file=sys.stderr,
        )
        try:
            while self.active(ts).any():
                before = done_now(ts)
                step_before = self.shard.get(ts.step).copy()
                t0 = time.perf_counter()
                ts, explore = self.chunk(ts)
                explore = self.shard.get(explore)  # waits for the chunk
                dt = time.perf_counter() - t0
                self.wall += dt
                steps = int((self.shard.get(ts.step) - step_before).sum())
                self.collect(ts, explore, step_before)
                self.write_tables()
                save_checkpoint(ckpt, self.shard.get(ts), self.host_tables())
                bar.set_postfix_str(self.progress_text(steps / max(dt, 1e-9)), refresh=False)
                bar.update(done_now(ts) - before)
        finally:
            bar.close()
        return ts

    def finish(self, ts: TrainState) -> dict[str, Any]:
        save_params(self.out / "params.npz", self.cfg, self.shard.get(ts.params))
        steps = int(self.shard.get(ts.step).sum())
        summary: dict[str, Any] = {
            "wall_clock_s": round(self.wall, 2),
            "env_steps": steps,
            "steps_per_s": round(steps / max(self.wall, 1e-9), 1),
            "buffer_capacity": self.cfg.buffer_capacity,
            "buffer_bytes_per_seed": buffer_bytes(
                self.cfg.buffer_capacity, self.trainer.env.obs_size, self.trainer.env_params.max_steps
            ),
            "machine": f"{platform.machine()} {os.cpu_count()} cores, jax {jax.__version__} "
            f"on {jax.default_backend()}",
            "devices": self.shard.n_devices,
            "processes": jax.process_count(),
            "last50": {},
        }
        rows = np.asarray(self.rows, np.float64).reshape(-1, len(METRIC_COLUMNS))
        for s in self.cfg.strategies:
            mine = rows[rows[:, 0] == STRATEGIES.index(s)]
            per_seed_ret, per_seed_goals = [], []
            for seed in np.unique(mine[:, 1]):
                ms = mine[mine[:, 1] == seed]
                ms = ms[np.argsort(ms[:, 2])][-50:]
                per_seed_ret.append(ms[:, 3].mean())
                per_seed_goals.append(ms[:, 5].mean())
            summary["last50"][s] = {
                "return_mean": round(float(np.mean(per_seed_ret)), 2),
                "return_std_over_seeds": round(float(np.std(per_seed_ret)), 2),
                "goals_per_episode": round(float(np.mean(per_seed_goals)), 3),
            }
        atomic_write_text(self.out / "summary.json", json.dumps(summary, indent=2) + "\n")
        return summary


def default_out(config_path: str | None) -> Path:
    stem = Path(config_path).stem if config_path else "default"
    return Path("runs") / f"{stem}-{time.strftime('%Y%m%d-%H%M%S')}"


def train_from_config(cfg: Config, out: Path, quiet: bool = False) -> dict[str, Any]:
    """Start a new run in ``out`` (must not exist or be empty) and train it to the end."""
    if out.exists() and any(out.iterdir()) and is_writer():
        raise RunError(f"run directory {out} already exists and is not empty (use --resume {out})")
    run = Run(cfg, out, quiet)  # builds the env first: a bad maze leaves no directory
    if is_writer():
        out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "config.yaml", dump_config(cfg))
    ts = run.train(run.fresh_state())
    return run.finish(ts)


def resume(out: Path, quiet: bool = False) -> dict[str, Any]:
    """Continue a run from its last checkpoint (or from the start if it has none)."""
    if not out.is_dir():
        raise RunError(f"run directory {out} does not exist")
    cfg_path = out / "config.yaml"
    if not cfg_path.is_file():
        raise RunError(f"{out} is not a run directory (no config.yaml)")
    cfg = load_config(str(cfg_path))
    run = Run(cfg, out, quiet)
    ckpt = out / "checkpoints" / "last.npz"
    if ckpt.is_file():
        template = jax.eval_shape(jax.vmap(run.trainer.init), *run_keys(cfg))
        template = jax.tree.map(lambda s: np.zeros((cfg.n_runs, *s.shape[1:]), s.dtype), template)
        ts, host = load_checkpoint(ckpt, template)
        ts = run.shard.put(ts)
        run.restore_host(host)
    else:
        ts = run.fresh_state()
    ts = run.train(ts)
    return run.finish(ts)


def _print_summary(out: Path, summary: dict[str, Any]) -> None:
    print(f"results in {out}/ (metrics.csv, params.npz, summary.json)")
    print(
        f"trained {summary['env_steps']} env steps in {summary['wall_clock_s']} s "
        f"({summary['steps_per_s']:.0f} steps/s)"
    )
    for s, v in summary["last50"].items():
        print(
            f"  {s:15s} last-50-episode return {v['return_mean']:9.1f} "
            f"(std over seeds {v['return_std_over_seeds']:.1f}), goals/episode {v['goals_per_episode']:.2f}"
        )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m jaxnav.train",
        description="Train DQN with EBE and epsilon-greedy exploration on a maze, many seeds at once.",
    )
    p.add_argument("items", nargs="*", metavar="CONFIG [key=value ...]",
                   help="a YAML config (path, or a name in configs/) then dotted overrides")
    p.add_argument("--out", help="run directory (default runs/<config>-<time>)")
    p.add_argument("--resume", metavar="RUN_DIR", help="continue a killed run from its last checkpoint")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    initialize()  # multi-host, when jax.distributed's variables are set
    try:
        if args.resume:
            if args.items or args.out:
                raise RunError("--resume takes only the run directory (its config.yaml is used)")
            out = Path(args.resume)
            summary = resume(out, args.quiet)
        else:
            config_path = None
            overrides = list(args.items)
            if overrides and "=" not in overrides[0]:
                config_path = resolve_config_path(overrides.pop(0))
            cfg = load_config(config_path, overrides)
            out = Path(args.out) if args.out else default_out(config_path)
            summary = train_from_config(cfg, out, args.quiet)
    except (ConfigError, MazeError, RunError) as e:
        print(f"jaxnav.train: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\njaxnav.train: interrupted; continue with --resume", file=sys.stderr)
        return 130
    if is_writer():
        _print_summary(out, summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
