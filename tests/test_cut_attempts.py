"""jaxnav.report.cut_attempts and ``jaxnav probe cut-attempts``: how long the attempts
an episode's end cut off had lasted, by a hand-made table and against the test's own
attempt records; and the line ``jaxnav evaluate`` prints about such waits, against the
table."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from jaxnav.commands.probe import main as probe
from jaxnav.core.config import load_config
from jaxnav.env import from_config
from jaxnav.experiments.baselines import evaluate_world
from jaxnav.report import cut_attempts as cut
from jaxnav.report.nav_tables import long_waits_text
from jaxnav.report.navigation import CUT

ROOT = Path(__file__).resolve().parents[1]

HEAD = "strategy,seed,mode,maze,episode,successes,timeouts,collisions,time_s,cut,drive_s\n"


def test_a_wait_at_the_end_of_an_episode_is_read_and_a_failed_episode_is_not(tmp_path, capsys):
    f = tmp_path / "results.csv"
    f.write_text(
        HEAD
        + "a,0,greedy,m,0,3,0,0,30.0,1,100.0\n"  # a 70 s wait after three goals in 30 s
        + "a,0,greedy,m,1,5,0,0,90.0,1,100.0\n"  # a 10 s cut attempt
        + "a,0,greedy,m,2,2,0,1,20.0,0,40.0\n"  # ended in a collision: nothing cut
        + "a,0,greedy,m,3,1,1,0,10.0,1,100.0\n"  # a time-out before its cut attempt
        + "a,0,exploring,m,0,0,0,0,0.0,1,100.0\n"  # not a greedy test
    )
    ((driver, maze, n, ending, read, longer, longest, ttg, unread),) = cut.table(f, 60.0)
    assert (driver, maze, n, ending, read, longer, unread) == ("a", "m", 4, 3, 2, 1, 1)
    assert longest == pytest.approx(70.0) and ttg == pytest.approx(150.0 / 11)
    assert probe(["cut-attempts", str(tmp_path), "--over", "60"]) == 0  # the folder's files
    lines = capsys.readouterr().out.splitlines()
    assert "longer than 60 s" in lines[0] and len(lines) == 3
    assert lines[2] == "| results.csv | a | m | 4 | 3 | 1 of 2 | 70.0 | 13.6 | 1 |"


@pytest.mark.slow  # 4 s on 2 cores
def test_the_cut_time_is_the_cut_attempt_the_test_recorded(tmp_path):
    cfg = load_config(None, ["env.maze=square4", "env.max_steps=150"])
    world = evaluate_world("oracle", cfg, n_seeds=2, n_episodes=3)
    f = tmp_path / "results.csv"
    f.write_text(world.text)
    dt = float(from_config(cfg)[1].dt)
    records = []
    for a, _ in world.attempts["square4"]:
        records += list(a.steps[a.outcome == CUT] * dt)
    ((*_, read, longer, longest, _, unread),) = cut.table(f, 10.0)
    assert unread == 0 and read == len(records) > 0
    assert longer == sum(r > 10.0 for r in records)
    assert longest == pytest.approx(max(records), abs=1e-3)
    assert np.isfinite(longest)


def test_a_missing_file_or_column_is_one_line_and_exit_2(tmp_path, capsys):
    def refused(path, message):
        assert probe(["cut-attempts", str(path)]) == 2
        out, err = capsys.readouterr()
        assert out == ""  # no table begun
        assert err.startswith("jaxnav probe cut-attempts: error: ") and err.count("\n") == 1
        assert message in err, err

    refused(tmp_path / "none.csv", "no file or folder")
    bad = tmp_path / "bad.csv"
    bad.write_text("strategy,maze\na,m\n")
    refused(bad, "no column 'mode'")
    bad.write_text(HEAD + "a,0,greedy,m,0,x,0,0,30.0,1,100.0\n")  # a count that is no number
    refused(bad, "a row that is not a test's")


def test_evaluate_says_which_drivers_waited_as_the_table_counts():
    """The line ``jaxnav evaluate`` prints under its tables against this table, on
    every test of the committed driving study: DWA waits on stage 4, nothing else does
    for longer than a minute more than once a world."""
    folder = ROOT / "docs" / "driving"
    seen = 0
    for f in cut.files_of([str(folder)]):
        rows = [r for r in csv.DictReader(f.open()) if r["mode"] == "greedy"]
        expected = {}
        for driver, _maze, _, _, read, longer, *_ in cut.table(f, 60.0):
            k, n = expected.get(driver, (0, 0))
            expected[driver] = (k + longer, n + read)
        lines = long_waits_text(rows).splitlines()
        said = {line.split(":")[0]: line for line in lines}
        for driver, (k, _n) in expected.items():
            if k:
                assert f"{driver}: stalled in {k} of its " in said[driver], (f, driver)
                seen += 1
            else:
                assert driver not in said, (f, driver)
    assert seen > 0


def test_no_line_where_nothing_waited():
    row = dict(zip(HEAD.strip().split(","), "oracle,0,greedy,m,0,3,0,0,30.0,1,50.0".split(",")))
    assert long_waits_text([row]) == ""
    row["drive_s"] = "100.0"  # a 70 s wait
    line = long_waits_text([row])
    assert line.startswith("oracle: stalled in 1 of its 1 test episodes: on one goal for over 60 s")
    assert "env.attempt_limit=300 " in line and "\n" not in line
