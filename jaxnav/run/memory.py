"""The memory check a command makes before it allocates a run: the replay memory the
config declares (:meth:`jaxnav.core.config.Config.memory_estimate`) and, with
``env.maze_bank``, the banks of layouts, whose size only the environment knows."""

from __future__ import annotations

import sys

from jaxnav.core import cli
from jaxnav.core.config import Config


def grid_bytes(cfg: Config) -> int:
    """Bytes an occupancy-grid world adds (0 for any other): the grid's cells, once per
    run where each environment holds its own (a drawn family), and every environment's
    grid LiDAR walk at once (a crossing's distance, cell and lookup per beam and line)."""
    from jaxnav.core import worlds

    if not (worlds.source_of(cfg.env.maze) or cfg.env.generator == "barn"):
        return 0
    from jaxnav.env import from_config  # JAX only where a grid is sized

    env, params = from_config(cfg)
    grid = params.maze.grid
    if grid is None:
        return 0
    envs = cfg.n_runs * {"pqn": cfg.pqn.num_envs, "sac": cfg.sac.num_envs}.get(cfg.agent, 1)
    beams = env.scan_beams or env.n_beams
    walk = envs * beams * (2 * grid.reach + 1) * 4 * 4
    cells = grid.occupied.size * (envs if env.generates else 1)
    return walk + cells


def confirm_memory(cfg: Config, yes: bool, quiet: bool) -> None:
    """:func:`jaxnav.core.cli.confirm_memory` of the runs' replay memory and, with
    ``env.maze_bank``, their banks of layouts (their size said unless ``quiet``), and an
    occupancy grid's cells and LiDAR walk (:func:`grid_bytes`)."""
    grid = grid_bytes(cfg)
    if not cfg.env.maze_bank:
        what = "replay memory and the grid's LiDAR walk" if grid else "replay memory"
        cli.confirm_memory(cfg.memory_estimate() + grid, yes, what=what)
        return
    from jaxnav.env import from_config  # JAX only where a bank is sized

    per = from_config(cfg, prepare=False)[0].layout_bytes()
    bank = per * cfg.env.maze_bank
    if not quiet:
        print(
            f"maze bank: {cfg.env.maze_bank} layouts of {per / 1024:.1f} KiB, "
            f"{bank / 2**20:.1f} MiB per run, {bank * cfg.n_runs / 2**20:.1f} MiB in all"
            + (", twice that while a new bank is drawn" if cfg.env.maze_bank_refresh else ""),
            file=sys.stderr,
        )
    if cfg.env.maze_bank_refresh:  # the old bank and the new one while it is drawn
        bank *= 2
    what = "replay and maze-bank memory"
    cli.confirm_memory(cfg.memory_estimate() + bank * cfg.n_runs + grid, yes, what=what)
