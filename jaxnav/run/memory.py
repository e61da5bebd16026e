"""The memory check a command makes before it allocates a run: the replay memory the
config declares (:meth:`jaxnav.core.config.Config.memory_estimate`) and, with
``env.maze_bank``, the banks of layouts, whose size only the environment knows."""

from __future__ import annotations

import sys

from jaxnav.core import cli
from jaxnav.core.config import Config


def confirm_memory(cfg: Config, yes: bool, quiet: bool) -> None:
    """:func:`jaxnav.core.cli.confirm_memory` of the runs' replay memory and, with
    ``env.maze_bank``, their banks of layouts (their size said unless ``quiet``)."""
    if not cfg.env.maze_bank:
        cli.confirm_memory(cfg.memory_estimate(), yes)
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
    cli.confirm_memory(cfg.memory_estimate() + bank * cfg.n_runs, yes, what=what)
