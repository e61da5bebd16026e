"""Sim-to-sim campaigns (``jaxnav study sim2sim_realism``, ``sim2sim_wheel_limit``): the
shipped files are the committed campaigns' arms, each arm's MuJoCo test runs in its own
process with the arm's options, an interrupted campaign resumes, and the page comes from
its CSV and JSON alone."""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import pytest

from jaxnav.core.config import load_config
from jaxnav.core.errors import ConfigError, JaxnavError
from jaxnav.core.shipped import CONFIG_DIR
from jaxnav.experiments import campaign, studyfile
from jaxnav.report.sim2sim_tables import REALISM_COLUMNS, SUMMARY_COLUMNS, campaign_markdown

ROOT = Path(__file__).resolve().parents[1]
REALISM = str(CONFIG_DIR / "studies" / "sim2sim_realism.yaml")
WHEEL_LIMIT = str(CONFIG_DIR / "studies" / "sim2sim_wheel_limit.yaml")


def _made(stem: str) -> dict:
    return json.loads((ROOT / "docs" / f"{stem}.json").read_text())


@pytest.mark.parametrize(
    "path, stem", [(REALISM, "sim2sim_realism"), (WHEEL_LIMIT, "sim2sim_wheel_limit")]
)
def test_the_shipped_campaigns_are_the_committed_pages_arms(path, stem):
    assert studyfile.kind_of(path) == "sim2sim"
    study = campaign.load_study(path)
    made = _made(stem)
    assert made["title"] == study.title
    assert [(a["arm"], a["what"]) for a in made["arms"]] == [
        (arm.name, campaign._shown(study, arm)) for arm in study.arms
    ]
    rows = csv.DictReader(io.StringIO((ROOT / "docs" / f"{stem}.csv").read_text()))
    assert list(dict.fromkeys(r["option"] for r in rows)) == [a.name for a in study.arms]
    seeds = load_config("paper_no_obstacles", [f"seeds={study.seeds}"])
    for arm in study.arms:
        cfg = campaign.arm_config(study, arm)
        assert cfg.seeds == study.seeds and cfg.episodes == seeds.episodes


def test_the_wheel_limit_arms_train_test_and_clip_as_their_page_says():
    study = campaign.load_study(WHEEL_LIMIT)
    plain, limited, unlimited = study.arms
    assert plain.trains() and limited.trains() and not unlimited.trains()
    assert (plain.wheel_limit, limited.wheel_limit, unlimited.wheel_limit) == (True, True, False)
    assert campaign.arm_config(study, limited).env.wheel_limit
    assert campaign.arm_config(study, unlimited) == campaign.arm_config(study, plain)
    assert campaign.arm_run(study, Path("o"), unlimited) == Path("o") / "plain"


@pytest.mark.parametrize(
    "items, message",
    [
        (["seeds=0"], "seeds must be at least 1"),
        (["arms.plain.polices=x"], "unknown key 'polices'"),
        (["arms.plain.policies=nowhere"], "policies must name an arm above it that trains"),
        (["arms.plain_unlimited.settings.env.wheel_limit=true"], "trains nothing"),
        (["arms.plain.settings.env.max_stepz=3"], "unknown key 'env.max_stepz'"),
        (["config=nowhere"], "no shipped config 'nowhere'"),
    ],
)
def test_a_wrong_campaign_is_one_line_naming_the_problem(items, message):
    with pytest.raises(ConfigError) as e:
        campaign.load_study(WHEEL_LIMIT, items)
    assert message in str(e.value) and "\n" not in str(e.value)


class _FakeTest:
    """``jaxnav sim2sim`` as a process: its CSV (every seed and strategy, both
    simulators) and its log's timing line, written at once."""

    calls: list[list[str]] = []

    def __init__(self, argv, log):
        self.argv = argv
        _FakeTest.calls.append(argv)
        out = Path(argv[argv.index("--out") + 1])
        seeds = argv[argv.index("--seeds") + 1 : argv.index("--episodes")]
        rows = [
            [sim, s, seed, "square2", 1, 100.0 + int(seed), 1.0, 0.0, 50]
            for sim in ("jaxnav", "mujoco")
            for s in ("ebe", "epsilon_greedy")
            for seed in seeds
        ]
        with out.open("w") as f:
            w = csv.writer(f, lineterminator="\n")
            w.writerow(SUMMARY_COLUMNS)
            w.writerows(rows)
        log.write_text("square2: 4 policies x 1 episodes in MuJoCo, 90 s\n")

    def wait(self):
        return 0

    def poll(self):
        return 0


def _fake_train(cell, quiet, say):
    cell.run.mkdir(parents=True, exist_ok=True)
    (cell.run / "summary.json").write_text(json.dumps({"wall_clock_s": 120.0}))
    return 120.0, "trained"


@pytest.mark.slow  # 3 s on 2 cores
def test_a_campaign_tests_each_arm_in_its_own_process_and_resumes(tmp_path, monkeypatch):
    monkeypatch.setattr(campaign, "_check_mujoco", lambda: None)
    monkeypatch.setattr(campaign.runner, "train", _fake_train)
    monkeypatch.setattr(campaign, "start_test", _FakeTest)
    _FakeTest.calls = []
    study = campaign.load_study(WHEEL_LIMIT, ["seeds=2"])
    out = tmp_path / "o"
    data = campaign.run_study(study, out, False, True, "jaxnav study sim2sim_wheel_limit")
    runs = [c[c.index("jaxnav.commands.sim2sim") + 1] for c in _FakeTest.calls]
    assert runs == [str(out / "plain"), str(out / "wheel_limit"), str(out / "plain")]
    assert ["--wheel-limit" in c for c in _FakeTest.calls] == [True, True, False]
    assert all(
        c[c.index("--seeds") + 1 : c.index("--episodes")] == ["0", "1"] for c in _FakeTest.calls
    )
    rows = list(csv.DictReader(io.StringIO((data / "campaign.csv").read_text())))
    assert tuple(rows[0]) == REALISM_COLUMNS and len(rows) == 3 * 2 * 2 * 2
    made = json.loads((data / "campaign.json").read_text())
    assert [(a["arm"], a["train_min"], a["reused"], a["mujoco_min"]) for a in made["arms"]] == [
        ("plain", 2.0, None, 1.5),
        ("wheel_limit", 2.0, None, 1.5),
        ("plain_unlimited", None, "plain's run", 1.5),
    ]
    assert made["column"] == "arm" and "`jaxnav study sim2sim_wheel_limit`" in made["how"]
    assert made["how"].endswith("read the intervals.")
    page = tmp_path / "docs" / "wl.md"
    page.parent.mkdir()
    written = campaign.publish(study, out, page)
    assert written == [page, page.with_suffix(".csv"), page.with_suffix(".json")]
    assert page.read_text().startswith(f"# {study.title}\n")  # the slow test: all of it
    assert (
        "| plain_unlimited | plain's policies; MuJoCo without the limit | plain's run | 1.5 min |"
        in page.read_text()
    )
    # a finished campaign: no MuJoCo test again; another study in the folder is refused
    _FakeTest.calls = []
    with pytest.raises(JaxnavError, match="use --resume"):
        campaign.run_study(study, out, False, True, "c")
    campaign.run_study(study, out, True, True, "c")
    assert _FakeTest.calls == []
    with pytest.raises(JaxnavError, match="holds another study"):
        campaign.run_study(campaign.load_study(WHEEL_LIMIT), out, True, True, "c")


def test_a_failed_mujoco_test_is_one_line_naming_its_arm(tmp_path, monkeypatch):
    class Failing(_FakeTest):
        def __init__(self, argv, log):
            log.write_text("jaxnav sim2sim: error: no policy of seed 9\n")

        def wait(self):
            return 2

    monkeypatch.setattr(campaign, "_check_mujoco", lambda: None)
    monkeypatch.setattr(campaign.runner, "train", _fake_train)
    monkeypatch.setattr(campaign, "start_test", Failing)
    study = campaign.load_study(REALISM, ["seeds=1"])
    with pytest.raises(JaxnavError) as e:
        campaign.run_study(study, tmp_path / "o", False, True, "c")
    assert (
        str(e.value)
        == "the MuJoCo test of plain failed: jaxnav sim2sim: error: no policy of seed 9"
    )


def test_a_run_to_reuse_is_checked_before_any_training(tmp_path, monkeypatch):
    monkeypatch.setattr(campaign, "_check_mujoco", lambda: None)
    study = campaign.load_study(REALISM, [f"arms.plain.run={tmp_path / 'nowhere'}"])
    with pytest.raises(JaxnavError, match="does not exist"):
        campaign.run_study(study, tmp_path / "o", False, True, "c")
    assert not (tmp_path / "o").exists()


TINY = """\
kind: sim2sim
title: Tiny
config: paper_no_obstacles
seeds: 1
episodes: 1
settings: {episodes: 4, env: {max_steps: 60}, run: {test_mazes: [square2], test_episodes: 2}}
arms:
  plain: {}
  delayed: {settings: {env: {action_delay: true}}}
  plain_limited: {policies: plain, wheel_limit: true}
"""


@pytest.mark.slow
def test_a_tiny_campaign_end_to_end_in_mujoco(tmp_path):
    pytest.importorskip("mujoco")
    path = tmp_path / "s.yaml"
    path.write_text(TINY)
    out, doc = tmp_path / "o", tmp_path / "tiny.md"
    cmd = [sys.executable, "-m", "jaxnav", "study", str(path), "--out", str(out), "--quiet"]
    done = subprocess.run([*cmd, "--doc", str(doc)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO(doc.with_suffix(".csv").read_text())))
    got = {(r["option"], r["simulator"], r["maze"]) for r in rows}
    assert got == {
        (a, s, "square2")
        for a in ("plain", "delayed", "plain_limited")
        for s in ("jaxnav", "mujoco")
    }
    made = json.loads(doc.with_suffix(".json").read_text())
    assert made["column"] == "override" and made["arms"][2]["reused"] == "plain's run"
    assert doc.read_text() == campaign_markdown(doc.with_suffix(".csv").read_text(), made)
    assert "`env.action_delay=true`" in doc.read_text()
