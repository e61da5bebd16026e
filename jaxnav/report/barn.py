"""BARN's metrics from test results, as the challenge's ``report_test.py`` computes them,
and the published rows jaxnav's sit beside (NumPy only, no JAX).

A run of BARN's protocol is one test episode on a ``barn:N`` maze with ``env.goal_ends``
(one goal attempt per episode): results.csv's row says whether it succeeded, collided
or timed out and, for a success, its time (``time_s``, steps x dt; BARN starts its clock
when the robot has moved 0.1 m). Per driver and seed, as ``report_test.py``: each
metric's mean over a world's runs, then over the worlds; the mean time over the worlds
with a success of their successful runs' mean. The score of a run is success x OT /
clip(AT, low OT, 8 OT), OT = the reference path's length / 2 m/s (:data:`CLIPS`:
``score``, low 2, with the path from today's start (-2.25, 3) as ``run.py`` measures it;
``score_2022``, low 4, with the path from (-2, 3), as ``report_test.py`` computed every
figure published before 2026).
"""

from __future__ import annotations

import csv
import functools
import io
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent.parent / "configs" / "barn" / "barn.npz"
OPTIMAL_SPEED = 2.0  # m/s
CLIPS = {"score": (2.0, 8.0), "score_2022": (4.0, 8.0)}  # (low, high) x OT
METRICS = ("success", "collision", "timeout", "time_s", "score", "score_2022")

# What the field published, each with where it comes from (docs/barn.md's rows).
README_DWA = {
    "success": 0.88,
    "collision": 0.048,
    "timeout": 0.072,
    "time_s": 33.4715,
    "score_2022": 0.1693,
}
DRL_VO = {"score_2022": 0.2339}


@functools.cache
def path_lengths() -> tuple[np.ndarray, np.ndarray]:
    """f64[300] each: the reference paths' lengths (m) from today's start and 2022's."""
    with np.load(DATA) as z:
        return np.asarray(z["path_length"]), np.asarray(z["path_length_2022"])


def optimal_time(world: int, start_2022: bool = False) -> float:
    """OT of world ``world`` (s)."""
    return float(path_lengths()[int(start_2022)][world]) / OPTIMAL_SPEED


def score(success, time_s, ot, clip=CLIPS["score"]) -> np.ndarray:
    """success x OT / clip(AT, low OT, high OT), elementwise over runs."""
    lo, hi = clip
    ot = np.asarray(ot, np.float64)
    at = np.asarray(time_s, np.float64)
    return np.asarray(success, np.float64) * ot / np.clip(at, lo * ot, hi * ot)


def world_of(maze: str) -> int | None:
    head, _, tail = maze.partition(":")
    return int(tail) if head == "barn" and tail.isdigit() else None


def runs_of(results) -> list[dict]:
    """BARN's runs in a results.csv (its text, or its rows as dicts): per greedy test
    episode on a ``barn:N`` maze, {driver, seed, world, success, collision, timeout,
    time_s}."""
    out = []
    rows = csv.DictReader(io.StringIO(results)) if isinstance(results, str) else results
    for row in rows:
        world = world_of(row["maze"])
        if world is None or row.get("mode", "greedy") != "greedy":
            continue
        success = int(float(row["successes"])) > 0
        out.append(
            {
                "driver": row["strategy"],
                "seed": int(row["seed"]),
                "world": world,
                "success": success,
                "collision": int(float(row["collisions"])) > 0,
                "timeout": int(float(row["timeouts"])) > 0,
                "time_s": float(row["time_s"]) if success else float("nan"),
            }
        )
    return out


def seed_metrics(runs: list[dict]) -> dict[str, float]:
    """One driver's and seed's metrics over its runs, as report_test.py aggregates."""
    worlds = sorted({r["world"] for r in runs})
    per = {k: [] for k in METRICS}
    times = []
    for w in worlds:
        mine = [r for r in runs if r["world"] == w]
        success = np.array([r["success"] for r in mine], float)
        at = np.array([r["time_s"] for r in mine])
        for k in ("success", "collision", "timeout"):
            per[k].append(np.mean([r[k] for r in mine]))
        for k, start_2022 in (("score", False), ("score_2022", True)):
            ot = optimal_time(w, start_2022)
            per[k].append(np.mean(score(success, np.nan_to_num(at, nan=1e9), ot, CLIPS[k])))
        if success.any():
            times.append(np.nanmean(at[success > 0]))
    out = {k: float(np.mean(per[k])) for k in ("success", "collision", "timeout")}
    out["time_s"] = float(np.mean(times)) if times else float("nan")
    out["score"] = float(np.mean(per["score"]))
    out["score_2022"] = float(np.mean(per["score_2022"]))
    out["worlds"] = len(worlds)
    out["runs"] = len(runs)
    return out


def driver_metrics(runs: list[dict]) -> dict[str, dict[int, dict[str, float]]]:
    """{driver: {seed: metrics}} of the runs."""
    out: dict[str, dict[int, dict[str, float]]] = {}
    for driver in dict.fromkeys(r["driver"] for r in runs):
        mine = [r for r in runs if r["driver"] == driver]
        out[driver] = {
            seed: seed_metrics([r for r in mine if r["seed"] == seed])
            for seed in sorted({r["seed"] for r in mine})
        }
    return out


def dwa_out_runs(text: str) -> list[dict]:
    """The runs of a ``report_test.py`` output file (``res/dwa_out.txt``: world,
    success, collided, timed out, time, metric per line) as :func:`runs_of` gives them."""
    out = []
    for line in text.split("\n"):
        if not line.strip():
            continue
        world, success, collided, timeout, time_s, _ = line.split()
        ok = bool(int(success))
        out.append(
            {
                "driver": "dwa",
                "seed": 0,
                "world": int(world),
                "success": ok,
                "collision": bool(int(collided)),
                "timeout": bool(int(timeout)),
                "time_s": float(time_s) if ok else float("nan"),
            }
        )
    return out


def summary_text(results) -> str:
    """The BARN metrics of a results.csv's BARN runs (its text or rows), one line per
    driver and seed (as ``report_test.py`` prints them), or "" without any."""
    runs = runs_of(results)
    lines = []
    for driver, seeds in driver_metrics(runs).items():
        for seed, m in seeds.items():
            lines.append(
                f"BARN {driver} seed {seed} ({m['worlds']} worlds, {m['runs']} runs): "
                f"success {m['success']:.4f}, collision {m['collision']:.4f}, timeout "
                f"{m['timeout']:.4f}, avg time {m['time_s']:.2f} s, score {m['score']:.4f} "
                f"(clip 2-8 OT), score {m['score_2022']:.4f} (clip 4-8 OT, before 2024)"
            )
    return "\n".join(lines)


__all__ = [
    "CLIPS",
    "DRL_VO",
    "METRICS",
    "README_DWA",
    "driver_metrics",
    "dwa_out_runs",
    "optimal_time",
    "path_lengths",
    "runs_of",
    "score",
    "seed_metrics",
    "summary_text",
]
