"""The page of the reference drivers on every world (``docs/baselines.md``), from its
data file: results.csv rows (:data:`jaxnav.report.results.RESULT_COLUMNS`) with the
world each came from in a first column ``world``.

Per world and test maze (a drawn family's train and test layouts on their own lines)
and per driver: the navigation metrics of :mod:`jaxnav.report.navigation`, each the
mean over seeds [95% bootstrap CI]. No JAX here: the page is a pure function of the
file, so a test rebuilds it byte for byte.
"""

from __future__ import annotations

import csv
import io

from jaxnav.core import baselines
from jaxnav.report.markdown import markdown_table
from jaxnav.report.nav_tables import metric_cells
from jaxnav.report.navigation import METRICS, seed_metrics
from jaxnav.report.results import ordered_unique, read_results

PAGE_COLUMNS = ("world",)  # before results.csv's own


def world_rows(text: str) -> dict[str, str]:
    """{world: its rows as results.csv text} of the page's data file, in file order."""
    rows = list(csv.DictReader(io.StringIO(text)))
    if not rows:
        return {}
    columns = [c for c in rows[0] if c not in PAGE_COLUMNS]
    out = {}
    for world in ordered_unique(r["world"] for r in rows):
        buf = io.StringIO()
        w = csv.DictWriter(buf, columns, extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        w.writerows(r for r in rows if r["world"] == world)
        out[world] = buf.getvalue()
    return out


def table_rows(text: str) -> list[list[str]]:
    """The page's table: [world, test maze, driver, seeds, *METRICS cells] rows."""
    out = []
    for world, mine in world_rows(text).items():
        res = read_results(mine)
        for maze in ordered_unique(k[0] for k in res):
            for name in baselines.names():
                seeds = sorted(k[2] for k in res if k[:2] == (maze, name))
                if not seeds:
                    continue
                per_seed = [seed_metrics(res[(maze, name, s)]) for s in seeds]
                label = baselines.BASELINES[name].label
                shown = "" if maze == world else maze
                out.append([world, shown, label, str(len(seeds)), *metric_cells(per_seed)])
    return out


def baselines_markdown(text: str, command: str, machine: str, notes: list[str]) -> str:
    """The whole page from the data file's text, the command that wrote it, the machine
    it ran on and the page's notes on worlds (computed from the data by the caller)."""
    rows = table_rows(text)
    seeds = sorted({r[3] for r in rows})
    episodes = _episodes(text)
    L = [
        "# The reference drivers on every shipped world",
        "",
        "What each world allows, and what a classical planner makes of it. Every learned "
        "policy's test has these two rows beside it (`jaxnav evaluate`); this page drives "
        "them through each shipped world on its own, with the same test: the same test "
        "keys as a run's seeds, consecutive episodes with auto-reset, the world's step "
        "limit, and the goal attempts counted as in [navigation metrics]"
        "(reproducing.md#navigation-metrics).",
        "",
        "- **oracle**: " + baselines.BASELINES["oracle"].about + " (`jaxnav.planners.oracle`).",
        "- **DWA**: " + baselines.BASELINES["dwa"].about + " (`jaxnav.planners.dwa`).",
        "",
        f"Each cell is the mean over {', '.join(seeds)} seeds [95% bootstrap CI] of each "
        f"seed's metric over its {episodes} test episodes. `success`, `collision` and "
        "`timeout` share the decided goal attempts (they sum to 1); `cut` counts the "
        "attempts per episode that the episode's step limit cut off, which are left out of "
        "the rates; `spl` is success weighted by path length; `goals_per_min` the goals "
        "reached per minute of driving. A world is **solved** by a policy whose mean "
        f"success is within 0.02 of the oracle's on the same test "
        "(`jaxnav.report.navigation.solved`).",
        "",
        f"Written by `{command}` on {machine}.",
        "",
    ]
    header = ["world", "test maze", "driver", "seeds", *METRICS]
    L += markdown_table(header, rows)
    if notes:
        L += ["", "## Where the oracle falls short, and why", ""]
        L += [f"- {n}" for n in notes]
    return "\n".join(L) + "\n"


def _episodes(text: str) -> int:
    rows = list(csv.DictReader(io.StringIO(text)))
    per = {}
    for r in rows:
        per.setdefault((r["world"], r["maze"], r["strategy"], r["seed"]), set()).add(r["episode"])
    return max((len(v) for v in per.values()), default=0)


__all__ = ["PAGE_COLUMNS", "baselines_markdown", "table_rows", "world_rows"]
