"""``jaxnav drive``: a policy file played in a world without training, beside the oracle;
the shipped policies found by name, by the command and by the ROS nodes."""

from __future__ import annotations

import csv
import importlib.util
import io
from pathlib import Path

import numpy as np
import pytest

from jaxnav.commands.drive import main
from jaxnav.commands.export import main as export_main
from jaxnav.commands.train import main as train_main
from jaxnav.core.errors import PolicyError
from jaxnav.robot import shipped
from jaxnav.robot.deploy import Policy

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory):
    """A policy exported from a tiny paper run (one seed of EBE)."""
    tmp = tmp_path_factory.mktemp("drive")
    run = tmp / "run"
    tiny = ["smoke", "strategies=[ebe]", "seeds=1", "episodes=4", "--quiet", "--out", str(run)]
    assert train_main(tiny) == 0
    assert export_main([str(run), "--out", str(tmp / "p.npz")]) == 0
    return tmp / "p.npz"


@pytest.mark.slow  # 15 s on 2 cores
def test_drive_plays_the_policy_beside_the_oracle_and_draws_an_episode(
    policy_file, tmp_path, capsys
):
    out = tmp_path / "drive"
    argv = ["square2", "--policy", str(policy_file), "--episodes", "2", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "beside the oracle" in printed and "oracle" in printed.split("beside")[1]
    rows = list(csv.DictReader(io.StringIO((out / "eval" / "results.csv").read_text())))
    drivers = {r["strategy"] for r in rows}
    assert drivers == {"ebe", "oracle"} and {r["maze"] for r in rows} == {"square2"}
    assert len([r for r in rows if r["strategy"] == "ebe"]) == 2  # two greedy episodes
    assert (out / "plots" / "episode.gif").stat().st_size > 1000
    assert (out / "plots" / "trajectory_square2.png").is_file()
    # the policy as a run: the file's own network, array for array
    with np.load(out / "run" / "params.npz") as saved, np.load(policy_file) as exported:
        for name in Policy.load(policy_file).meta["layers"]:
            np.testing.assert_array_equal(
                saved[f"ebe/seed0/params/{name}/kernel"], exported[f"{name}/kernel"]
            )


@pytest.mark.slow  # its fixture is a slow test's
@pytest.mark.parametrize(
    "argv, message",
    [
        (["square2", "--policy", "drive_anywhre"], "no shipped policy of that name"),
        (["square2", "--policy", "POLICY", "--episodes", "0"], "--episodes must be at least 1"),
        (["nowhere", "--policy", "POLICY"], "unknown maze 'nowhere'"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(policy_file, tmp_path, capsys, argv, message):
    argv = [str(policy_file) if a == "POLICY" else a for a in argv]
    assert main([*argv, "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_a_shipped_policy_is_found_by_name_and_a_file_by_its_path(tmp_path, monkeypatch):
    (tmp_path / "drive_anywhere.npz").write_bytes(b"")
    monkeypatch.setattr(shipped, "POLICY_DIR", tmp_path)
    assert shipped.shipped_policies() == {"drive_anywhere": tmp_path / "drive_anywhere.npz"}
    assert shipped.policy_path("drive_anywhere") == tmp_path / "drive_anywhere.npz"
    other = tmp_path / "mine.npz"
    other.write_bytes(b"")
    assert shipped.policy_path(other) == other
    with pytest.raises(PolicyError, match=r"did you mean 'drive_anywhere'\?.*shipped: drive_any"):
        shipped.policy_path("drive_anywere")


@pytest.mark.parametrize("node", ["ros2_policy_node", "ros1_policy_node"])
def test_the_ros_nodes_take_a_shipped_policy_by_name(node, tmp_path, monkeypatch):
    path = ROOT / "examples" / f"{node}.py"
    if node == "ros1_policy_node" and importlib.util.find_spec("rospy") is None:
        pytest.skip("ROS 1's rospy is not installed")
    spec = importlib.util.spec_from_file_location(node, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    (tmp_path / "drive_anywhere.npz").write_bytes(b"")
    monkeypatch.setattr(shipped, "POLICY_DIR", tmp_path)
    argv = ["node", "--policy", "drive_anywhere", "--ros-args", "-p", "goal_topic:=/g"]
    assert module.policy_arg(argv) == "drive_anywhere"
    assert argv == ["node", "--ros-args", "-p", "goal_topic:=/g"]  # ROS keeps the rest
    assert module.policy_file("drive_anywhere") == str(tmp_path / "drive_anywhere.npz")
    assert module.policy_arg(["node"]) is None
    assert module.policy_arg(["node", "--policy"]) is None  # no value: the default stays
    with pytest.raises(PolicyError, match="did you mean 'drive_anywhere'"):
        module.policy_file("drive_anywere")


def test_a_node_finds_a_policy_beside_itself_before_a_shipped_one(tmp_path, monkeypatch):
    node, policies = tmp_path / "node", tmp_path / "policies"
    node.mkdir()
    policies.mkdir()
    (policies / "drive_anywhere.npz").write_bytes(b"")
    monkeypatch.setattr(shipped, "POLICY_DIR", policies)
    assert shipped.node_policy_file("drive_anywhere", node) == str(policies / "drive_anywhere.npz")
    (node / "drive_anywhere.npz").write_bytes(b"")
    assert shipped.node_policy_file("drive_anywhere", node) == str(node / "drive_anywhere.npz")
    # a robot without jaxnav's policies: the name as given, for the node's load to refuse
    monkeypatch.setattr(shipped, "POLICY_DIR", tmp_path / "none")
    assert shipped.node_policy_file("mine", node) == "mine"


@pytest.mark.slow  # the mixed config read and the oracle driven: 20-30 s
def test_the_shipped_policy_drives_only_the_world_named(tmp_path, capsys):
    """``jaxnav drive square4``, no training: the shipped generalist, trained on a mix of
    drawn worlds, is tested in square4 alone (not on its family's layouts too)."""
    out = tmp_path / "drive"
    assert main(["square4", "--episodes", "1", "--out", str(out), "--quiet"]) == 0
    rows = list(csv.DictReader(io.StringIO((out / "eval" / "results.csv").read_text())))
    assert {r["maze"] for r in rows} == {"square4"}
    assert {r["strategy"] for r in rows} == {"epsilon_greedy", "oracle"}
    assert (out / "plots" / "episode.gif").is_file()


def test_every_shipped_policy_comes_with_its_page():
    """Each shipped policy file has its page beside it (the config and the test that made
    it) and loads as a policy."""
    policies = shipped.shipped_policies()
    assert "drive_anywhere" in policies
    for name, path in policies.items():
        page = path.with_suffix(".md").read_text()
        assert f"jaxnav train {name}" in page and "| test maze |" in page
        assert Policy.load(path).meta["strategy"]
