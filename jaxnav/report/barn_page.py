"""``docs/barn.md``, and the README's line on BARN, from the committed data under
``docs/barn/`` (``jaxnav publish``; no JAX):

* ``oracle/results.csv``, ``dwa/results.csv``: ``jaxnav evaluate --baseline oracle|dwa
  barn --seeds 1 --out ...``; ``policy/results.csv``: ``jaxnav evaluate RUN
  --no-baselines`` of a ``jaxnav train drive_barn`` run (``policy_half``: of one with
  ``total_steps=409600``);
* ``burger/{oracle,dwa,anywhere}/results.csv``: the same test with the burger
  (``--baseline oracle|dwa barn robot=burger``; ``drive_anywhere``'s policies), BARN's
  greedy rows kept;
* ``footprint/rXXX/results.csv``: the oracle's on all 300 worlds with the Jackal as a
  disc of XXX mm (``env.robot_radius``);
* ``dwa_out.txt``: the challenge's own DWA runs (``res/dwa_out.txt``, MIT licence);
* ``made.json``: the commands, the machine and the notes the page quotes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from jaxnav.report import barn as rb
from jaxnav.report.markdown import interval, markdown_table
from jaxnav.report.stats import mean_ci

# (folder, the row's driver label, its simulator)
JAXNAV_ROWS = (
    ("oracle", "oracle (privileged planner)", "jaxnav"),
    ("dwa", "DWA with BARN's parameters (`run.dwa: barn`)", "jaxnav"),
    ("dwa_map", "the same DWA under a global planner that knows the map (`barn_map`)", "jaxnav"),
    ("policy", "`drive_barn` policy (PQN)", "jaxnav"),
    ("policy_half", "the same at half its budget (409,600 env steps a seed)", "jaxnav"),
)
# the burger in the same worlds and protocol (docs/barn/burger/FOLDER)
BURGER_ROWS = (
    ("oracle", "oracle (privileged planner)", "jaxnav"),
    ("dwa", "DWA (jaxnav's default parameters)", "jaxnav"),
    ("anywhere", "`drive_anywhere` policy (PQN), never trained on BARN", "jaxnav"),
)
GAZEBO = "Gazebo (the challenge's)"
HEADER = [
    "driver",
    "simulator",
    "seeds x worlds x runs",
    "success",
    "collision",
    "timeout",
    "time (s)",
    "score, clip 2-8 OT",
    "score, clip 4-8 OT (before 2024)",
]


def _cell(values: list[float], digits: int) -> str:
    """Mean over seeds with its 95% interval (n/a for one seed); NaN-free values only."""
    v = [x for x in values if not math.isnan(x)]
    if not v:
        return "n/a"
    return interval(mean_ci(np.asarray(v)), digits, missing="")


def _row(label: str, simulator: str, seeds: dict[int, dict[str, float]]) -> list[str]:
    ms = list(seeds.values())
    runs = sum(int(m["runs"]) for m in ms)
    worlds = max(int(m["worlds"]) for m in ms)
    return [
        label,
        simulator,
        f"{len(ms)} x {worlds} x {runs // max(1, len(ms) * worlds)}",
        *(_cell([m[k] for m in ms], 3) for k in ("success", "collision", "timeout")),
        _cell([m["time_s"] for m in ms], 1),
        _cell([m["score"] for m in ms], 4),
        _cell([m["score_2022"] for m in ms], 4),
    ]


def _seeds(folder: Path, specs) -> list[tuple[str, str, dict[int, dict[str, float]]]]:
    """(label, simulator, {seed: metrics}) of each row's results.csv under ``folder``."""
    out = []
    for sub, label, sim in specs:
        path = folder / sub / "results.csv"
        if not path.is_file():
            continue
        for seeds in rb.driver_metrics(rb.runs_of(path.read_text())).values():
            out.append((label, sim, seeds))
    return out


def table(root: Path) -> list[str]:
    """The main table: jaxnav's rows, then the published ones."""
    folder = root / "docs" / "barn"
    rows = [_row(*r) for r in _seeds(folder, JAXNAV_ROWS)]
    r = rb.README_DWA
    rows.append(
        [
            "DWA, the challenge's README",
            GAZEBO,
            "1 x 50 x 10",
            f"{r['success']:.3f}",
            f"{r['collision']:.3f}",
            f"{r['timeout']:.3f}",
            f"{r['time_s']:.1f}",
            "n/a",
            f"{r['score_2022']:.4f}",
        ]
    )
    out_txt = folder / "dwa_out.txt"
    if out_txt.is_file():
        seeds = {0: rb.seed_metrics(rb.dwa_out_runs(out_txt.read_text()))}
        rows.append(_row("DWA, `res/dwa_out.txt` recomputed", GAZEBO, seeds))
    rows.append(
        [
            "DRL-VO, 2022 simulation winner",
            GAZEBO,
            "50 x 10",
            *["n/a"] * 5,
            f"{rb.DRL_VO['score_2022']:.4f}",
        ]
    )
    return markdown_table(HEADER, rows)


def burger_rows(root: Path) -> list[tuple[str, str, dict[int, dict[str, float]]]]:
    """The burger's rows in the same worlds and protocol, read once: (label, simulator,
    {seed: metrics}) of each of :data:`BURGER_ROWS` with data."""
    return _seeds(root / "docs" / "barn" / "burger", BURGER_ROWS)


def burger_table(rows) -> list[str]:
    """The table of :func:`burger_rows` (none without their data)."""
    return markdown_table(HEADER, [_row(*r) for r in rows]) if rows else []


def burger_sentence(rows) -> str:
    """The burger's result in BARN's test worlds in one sentence, from
    :func:`burger_rows`."""
    got = {label: seeds for label, _, seeds in rows}
    oracle, dwa, policy = (got.get(label) for _, label, _ in BURGER_ROWS)
    if policy is None:
        return "The burger has not been tested in BARN's worlds."

    def mean(seeds, k) -> float:
        return float(np.mean([m[k] for m in seeds.values()]))

    refs = [
        f"{name} {mean(s, 'success'):.2f}"
        for name, s in (("the oracle", oracle), ("DWA", dwa))
        if s
    ]
    ms = list(policy.values())
    return (
        f"With the burger in BARN's {max(int(m['worlds']) for m in ms)} test worlds (BARN's "
        f"protocol, jaxnav's simulator), `drive_anywhere`, which never "
        f"trained on BARN, reaches a success of {_cell([m['success'] for m in ms], 2)} with "
        f"collisions {_cell([m['collision'] for m in ms], 2)} over its {len(ms)} seeds"
        + (f", beside {' and '.join(refs)} in the same worlds" if refs else "")
        + "."
    )


def footprint(root: Path) -> list[str]:
    """Which worlds the oracle passes with the Jackal as a disc of each radius."""
    folder = root / "docs" / "barn" / "footprint"
    files = sorted(folder.glob("r*/results.csv")) if folder.is_dir() else []
    if not files:
        return []
    rows = []
    for path in files:
        runs = rb.runs_of(path.read_text())
        passed = sorted({r["world"] for r in runs if r["success"]})
        worlds = sorted({r["world"] for r in runs})
        failed = [w for w in worlds if w not in passed]
        test = [w for w in worlds if w % 6 == 0]
        rows.append(
            [
                f"{int(path.parent.name[1:]) / 1000:.3f}",
                f"{len(passed)} / {len(worlds)}",
                f"{sum(w in passed for w in test)} / {len(test)}",
                ", ".join(map(str, failed)) if len(failed) <= 40 else f"{len(failed)} worlds",
            ]
        )
    header = ["disc radius (m)", "worlds passed", "test worlds passed", "worlds not passed"]
    return markdown_table(header, rows)


def barn_markdown(root: Path) -> str:
    """docs/barn.md."""
    made = json.loads((root / "docs" / "barn" / "made.json").read_text())
    lines = [
        "# BARN in jaxnav",
        "",
        "<!-- Generated by `jaxnav publish` from docs/barn/ (jaxnav/report/barn_page.py): edit",
        "the data or the code, not this page. -->",
        "",
        *made["intro"],
        "",
        "## Results on the 50 test worlds",
        "",
        "Per driver and seed, each metric's mean over a world's runs, then over the 50 worlds",
        "(as the challenge's `report_test.py`); time: over the worlds with a success, their",
        "successful runs' mean. jaxnav's rows: the mean over seeds with its 95% bootstrap",
        "interval where there are several. OT is the reference path's length over 2 m/s;",
        "the 2-8 OT score is today's (`run.py`, paths from (-2.25, 3)), the 4-8 OT score is",
        "what every figure published before 2024 used (`report_test.py`, paths from (-2, 3)).",
        "",
        *table(root),
        "",
        *made["notes"],
    ]
    rows = burger_rows(root)
    burger = burger_table(rows)
    if burger:
        lines += [
            "",
            "## The burger in BARN's worlds",
            "",
            *made.get("burger", []),
            "",
            burger_sentence(rows),
            "",
            *burger,
        ]
    fp = footprint(root)
    if fp:
        lines += ["", "## The Jackal's footprint as a disc", "", *made["footprint"], "", *fp]
    lines += ["", "## How these numbers were made", "", *made["commands"], ""]
    return "\n".join(lines)


def readme_line(root: Path) -> str:
    """The README's line on BARN."""
    made = json.loads((root / "docs" / "barn" / "made.json").read_text())
    return made["readme"]


__all__ = ["barn_markdown", "footprint", "readme_line", "table"]
