"""How long the attempts that an episode's end cut off had lasted, per driver and maze.

A cut attempt is left out of success (docs/reproducing.md, navigation metrics), so a
driver that stands still for the rest of an episode is never counted as failing. This
reads a test's per-episode rows (``eval/results.csv``, or a study's data folder of them)
and says, for each driver and test maze, how many greedy episodes ended on a cut attempt
and how many of those had lasted longer than ``over`` seconds, beside the longest and
the drivers' mean time to a goal. A cut attempt that lasted several times longer than a
goal takes is a wait the count does not see.

The cut attempt's time is the episode's driving time less its successful attempts'
(``drive_s - time_s``, :func:`jaxnav.report.nav_tables.cut_wait_s`). That is exact
where the episode has no collision and no time-out (a collision ends an episode; with an
attempt limit, a time-out may come before the cut attempt): such episodes are not read,
and their number is given. ``jaxnav evaluate`` prints the same count, pooled over its
test mazes, under its tables; ``jaxnav probe cut-attempts PATH ...`` prints this table.
"""

from __future__ import annotations

import csv
from collections import defaultdict
from pathlib import Path

from jaxnav.core.errors import JaxnavError
from jaxnav.report.nav_tables import cut_wait_s

NEEDED = ("strategy", "maze", "mode", "successes", "time_s", "cut", "drive_s")


def files_of(paths: list[str]) -> list[Path]:
    """Every results file named or in a folder named (sorted)."""
    out = []
    for p in map(Path, paths):
        if p.is_dir():
            out += sorted(f for f in p.glob("*.csv") if _has_columns(f))
        elif p.is_file():
            out.append(p)
        else:
            raise JaxnavError(f"no file or folder {p}")
    return out


def _has_columns(path: Path) -> bool:
    with path.open() as f:
        head = next(csv.reader(f), [])
    return all(c in head for c in NEEDED)


def table(path: Path, over: float) -> list[tuple]:
    """(driver, maze, episodes, ending cut, cut and read, longer than over, longest cut
    s, mean time to goal s, not read) per driver and maze of one results file."""
    with path.open() as f:
        reader = csv.DictReader(f)
        missing = [c for c in NEEDED if c not in (reader.fieldnames or ())]
        if missing:
            raise JaxnavError(f"{path} has no column {missing[0]!r}")
        groups = defaultdict(list)
        for row in reader:
            if row["mode"] == "greedy":
                groups[(row["strategy"], row["maze"])].append(row)
    rows = []
    for (driver, maze), episodes in groups.items():
        cut, unread, goals, goal_s = [], 0, 0.0, 0.0
        for e in episodes:
            goals += float(e["successes"])
            goal_s += float(e["time_s"])
            wait = cut_wait_s(e)
            if wait is not None:
                cut.append(wait)
            elif float(e["cut"]) > 0:
                unread += 1
        rows.append(
            (
                driver,
                maze,
                len(episodes),
                sum(1 for e in episodes if float(e["cut"]) > 0),
                len(cut),
                sum(1 for c in cut if c > over),
                max(cut, default=0.0),
                goal_s / goals if goals else float("nan"),
                unread,
            )
        )
    return rows


def cut_attempts_table(paths: list[str], over: float) -> str:
    """The markdown table of every results file named or in a folder named: a row per
    file, driver and maze (:func:`table`). Every file is read before any row is
    given; a file that is not a test's results is a :class:`JaxnavError` naming it."""
    lines = [
        f"| file | driver | maze | episodes | ending on a cut attempt | of those read, longer "
        f"than {over:g} s | longest cut attempt (s) | mean time to a goal (s) | not read |",
        "|---|---|---|--:|--:|--:|--:|--:|--:|",
    ]
    for path in files_of(paths):
        try:
            rows = table(path, over)
        except (ValueError, KeyError) as err:
            raise JaxnavError(f"{path}: a row that is not a test's: {err}") from None
        for driver, maze, n, ending, read, longer, longest, ttg, unread in rows:
            lines.append(
                f"| {path.name} | {driver} | {maze} | {n} | {ending} | {longer} of {read} "
                f"| {longest:.1f} | {ttg:.1f} | {unread} |"
            )
    return "\n".join(lines)
