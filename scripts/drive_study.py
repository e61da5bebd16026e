"""The policies that drive: each shipped ``drive_*`` config trained and tested, beside
the oracle and DWA, into docs/driving/ and docs/driving.md (and the README's results).

    python scripts/drive_study.py [--out runs/drive] [CONFIG ...]   # train, test, publish
    python scripts/drive_study.py --publish-only                    # the page from the data

Every config trains in one whole ``jaxnav train`` command with an empty compilation cache
(its seconds, compilation included, are what the page reports), then ``jaxnav evaluate``
tests it (greedy; the oracle's and DWA's rows on the same test keys). A finished run is
reused, so the script can be stopped and started again; run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jaxnav.core.config import load_config  # noqa: E402
from jaxnav.core.rundir import csv_text  # noqa: E402
from jaxnav.report import publish as report_publish  # noqa: E402
from jaxnav.report.driving_page import RUN_COLUMNS, RUNS  # noqa: E402

CONFIGS = (
    "drive_square4",
    "drive_obstacles",
    "drive_stage4",
    "drive_cylinders",
    "drive_rooms",
    "drive_grid4",
)
DOCS = ROOT / "docs" / "driving"


def jaxnav(*args: str, env: dict | None = None) -> float:
    """Run ``python -m jaxnav ARGS``; its wall seconds."""
    import os

    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "jaxnav", *args],
        cwd=ROOT,
        check=True,
        env={**os.environ, **(env or {})},
    )
    return time.perf_counter() - t0


def world_of(cfg) -> str:
    e = cfg.env
    return (
        f"{e.generator} {e.grid_rows}x{e.grid_cols}"
        if e.generator == "grid"
        else (e.generator or e.maze)
    )


def run_config(name: str, out: Path) -> dict:
    """Train (whole command, empty compilation cache) and test one config."""
    run = out / name
    timing = run / "command_s.json"
    if not (run / "summary.json").is_file():
        if run.exists():  # an interrupted run: its time would not be one command's
            raise SystemExit(f"{run} was interrupted: remove it and run again")
        with tempfile.TemporaryDirectory() as cache:
            seconds = jaxnav("train", name, "--out", str(run), "--yes", "--quiet",
                             env={"JAXNAV_CACHE": cache})  # fmt: skip
        timing.write_text(json.dumps({"command_s": round(seconds, 1)}))
    if not (run / "eval" / "results.csv").is_file():
        jaxnav("evaluate", str(run), "--episodes", "10")
    cfg = load_config(str(run / "config.yaml"))
    summary = json.loads((run / "summary.json").read_text())
    (DOCS / f"{name}.csv").write_text((run / "eval" / "results.csv").read_text())
    return {
        "config": name,
        "world": world_of(cfg),
        "command_s": json.loads(timing.read_text())["command_s"],
        "env_steps": int(summary["env_steps"]) // cfg.n_runs,
        "seeds": cfg.seeds,
        "strategy": cfg.strategies[0],
    }


def publish() -> None:
    for page in report_publish.publish(ROOT, ("driving-page", "driving")):
        print(f"wrote {page}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("configs", nargs="*", default=list(CONFIGS))
    p.add_argument("--out", default="runs/drive")
    p.add_argument("--publish-only", action="store_true")
    a = p.parse_args(argv)
    if not a.publish_only:
        from jaxnav.experiments.reproduce import machine_info

        DOCS.mkdir(parents=True, exist_ok=True)
        rows = {r["config"]: r for r in _read_runs()}
        for name in a.configs:
            rows[name] = run_config(name, ROOT / a.out)
            order = [c for c in CONFIGS if c in rows] + [c for c in rows if c not in CONFIGS]
            (DOCS / RUNS).write_text(
                csv_text(RUN_COLUMNS, [[rows[c][k] for k in RUN_COLUMNS] for c in order])
            )
        info = machine_info()
        machine = f"{info['CPU']}, {info['cores']}, {info['memory']}, JAX {info['JAX']}"
        command = "python scripts/drive_study.py"
        (DOCS / "run.json").write_text(json.dumps({"command": command, "machine": machine}) + "\n")
    publish()
    return 0


def _read_runs() -> list[dict]:
    path = DOCS / RUNS
    return list(csv.DictReader(io.StringIO(path.read_text()))) if path.is_file() else []


if __name__ == "__main__":
    raise SystemExit(main())
