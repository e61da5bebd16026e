"""What the figure modules share: the Agg backend, a colour and line style per arm,
the mean-and-band curve, the test mode in a title, and writing a figure whole.

Every figure module (``fig_*``) imports matplotlib through this one, so the
non-interactive backend is chosen before ``pyplot`` is first imported.
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import Any, NamedTuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from jaxnav.core import rundir  # noqa: E402
from jaxnav.report import stats  # noqa: E402
from jaxnav.report.results import MODE_NAMES, arm_strategy, arms_in  # noqa: E402

COLORS = {"ebe": "tab:blue", "epsilon_greedy": "tab:orange", "boltzmann": "tab:green"}
COLORMAPS = {"ebe": "Blues", "epsilon_greedy": "Oranges", "boltzmann": "Greens"}
# Strategies registered beyond the three (jaxnav.core.strategies), in the order met.
MORE_COLORS = (
    ("tab:purple", "Purples"),
    ("tab:red", "Reds"),
    ("tab:brown", "YlOrBr"),
    ("tab:cyan", "GnBu"),
    ("tab:pink", "RdPu"),
    ("tab:olive", "YlGn"),
)
# A strategy's sweep points: shades of its colour map, and each its own dash and hatch
# so that neighbouring shades still read apart (and in grey print).
LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 3)))
HATCHES = ("", "//", "..", "xx", "\\\\", "oo")


def strategy_colors(strategies) -> dict[str, tuple[Any, str]]:
    """(colour, colour map) per strategy: the three built-in ones' own, then
    MORE_COLORS in turn for other registered strategies (grey after six)."""
    others = iter(MORE_COLORS)
    out = {}
    for s in dict.fromkeys(strategies):
        known = s in COLORS
        out[s] = (COLORS[s], COLORMAPS[s]) if known else next(others, ("0.4", "Greys"))
    return out


class ArmStyle(NamedTuple):
    """How one arm is drawn: a colour, a line style for curves, a hatch for bars."""

    color: Any
    linestyle: Any
    hatch: str


def arm_styles(arms) -> dict[str, ArmStyle]:
    """A style per arm, each pair (colour, line style) different from every other.

    A strategy with one arm: the strategy's colour, a solid line. A strategy with
    several sweep points: shades of its colour map from light to dark in point order,
    and the i-th point the i-th line style and hatch (cycling after six)."""
    out: dict[str, ArmStyle] = {}
    arms = arms_in(arms)
    for s, (color, cmap) in strategy_colors(arm_strategy(a) for a in arms).items():
        mine = [a for a in arms if arm_strategy(a) == s]
        if len(mine) == 1:
            out[mine[0]] = ArmStyle(color, "-", "")
            continue
        for i, a in enumerate(mine):
            shade = plt.get_cmap(cmap)(0.5 + 0.45 * i / (len(mine) - 1))
            out[a] = ArmStyle(shade, LINESTYLES[i % len(LINESTYLES)], HATCHES[i % len(HATCHES)])
    return out


def arm_colors(arms) -> dict[str, Any]:
    """The colour of each arm's style (:func:`arm_styles`)."""
    return {a: style.color for a, style in arm_styles(arms).items()}


def mode_title(mode: str) -> str:
    """The test mode as a figure title names it: ``test mode: greedy (argmax Q, ...)``."""
    return f"test mode: {MODE_NAMES.get(mode, mode)}"


def band(ax, x, y, style: ArmStyle, label: str | None, lw: float = 1.6, alpha: float = 0.25):
    """Mean over seeds of y f[seeds, T] as a line and its 95% bootstrap band (2+ seeds)."""
    mean, low, high = stats.bootstrap_band(y)
    ax.plot(x, mean, color=style.color, ls=style.linestyle, lw=lw, label=label)
    if y.shape[0] > 1:
        ax.fill_between(x, low, high, color=style.color, alpha=alpha, lw=0)


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
