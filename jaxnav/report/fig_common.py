"""What the figure modules share: the Agg backend, a colour per arm, the
mean-and-band curve, and writing a figure whole.

Every figure module (``fig_*``) imports matplotlib through this one, so the
non-interactive backend is chosen before ``pyplot`` is first imported.
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from jaxnav.core import rundir  # noqa: E402
from jaxnav.report import stats  # noqa: E402
from jaxnav.report.results import arm_strategy  # noqa: E402

COLORS = {"ebe": "tab:blue", "epsilon_greedy": "tab:orange", "boltzmann": "tab:green"}
COLORMAPS = {"ebe": "Blues", "epsilon_greedy": "Oranges", "boltzmann": "Greens"}


def arm_colors(arms) -> dict[str, Any]:
    """A colour per arm: its strategy's colour, or, where a strategy has several sweep
    points, shades of the strategy's colour map from light to dark in point order."""
    out: dict[str, Any] = {}
    for s in COLORS:
        mine = [a for a in arms if arm_strategy(a) == s]
        if len(mine) == 1:
            out[mine[0]] = COLORS[s]
        for i, a in enumerate(mine if len(mine) > 1 else []):
            out[a] = plt.get_cmap(COLORMAPS[s])(0.35 + 0.6 * i / (len(mine) - 1))
    return out


def band(ax, x, y, color, label):
    """Mean over seeds of y f[seeds, T] as a line and its 95% bootstrap band (2+ seeds)."""
    mean, low, high = stats.bootstrap_band(y)
    ax.plot(x, mean, color=color, lw=1.6, label=label)
    if y.shape[0] > 1:
        ax.fill_between(x, low, high, color=color, alpha=0.25, lw=0)


def save_fig(fig, path: Path, **kw) -> Path:
    """Render a figure, close it and write the file whole or not at all."""
    buf = io.BytesIO()
    fig.savefig(buf, format=path.suffix.lstrip("."), **kw)
    plt.close(fig)
    rundir.atomic_write_bytes(path, buf.getvalue())
    return path


def safe_name(maze: str) -> str:
    """A maze name or path as a file-name part (``configs/mazes/corridor.yaml`` -> ``corridor``)."""
    stem = Path(maze).stem if maze.endswith((".yaml", ".yml")) else maze
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", stem) or "maze"


def is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
