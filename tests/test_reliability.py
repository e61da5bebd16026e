"""Divergence, absurd mazes and non-finite policies: one line, a non-zero exit, and
nothing good lost."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from jaxnav.commands.evaluate import main as evaluate_main
from jaxnav.commands.train import main as train_main
from jaxnav.core import rundir
from jaxnav.core.errors import MazeError, PolicyError
from jaxnav.robot.deploy import Policy
from jaxnav.world.maps import load_maze_file

# Learning starts at step 64: with this learning rate the first update is not finite.
DIVERGING = ["configs/smoke.yaml", "dqn.lr=1e9", "episodes=6", "env.max_steps=40"]


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if not line.startswith("warning:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.slow
def test_divergence_stops_with_one_line_and_keeps_the_good_checkpoint(tmp_path, capsys):
    out = tmp_path / "run"
    # Chunks of 50 steps: the first ends before learning starts and is checkpointed.
    chunks = ["run.chunk_steps=50", "run.chunk_s=0", "run.checkpoint_s=0"]  # each checkpointed
    assert train_main([*DIVERGING, *chunks, "--quiet", "--out", str(out)]) == 2
    line = _one_line(capsys)
    assert "diverged" in line and "seed" in line and "step 65" in line, line
    assert not (out / rundir.PARAMS).exists() and not (out / rundir.SUMMARY).exists()
    ckpt = rundir.read_npz(out / rundir.CHECKPOINT)
    assert np.all(ckpt["state.step"] == 50)  # the state before the divergence
    for k, v in ckpt.items():
        if k.startswith("state.params"):
            assert np.isfinite(v).all(), k
    # metrics.csv keeps the episodes finished before the stop (40-step episodes).
    rows = rundir.CsvLog(out / rundir.METRICS, ()).read()
    assert len(rows) >= 4 and all(np.isfinite(float(r["return"])) for r in rows)

    # The same directory with a truncated checkpoint, or one from another version.
    for damage, message in [("truncate", "checkpoint"), ("drop a leaf", "another jaxnav version")]:
        broken = tmp_path / damage.replace(" ", "_")
        shutil.copytree(out, broken)
        path = broken / rundir.CHECKPOINT
        if damage == "truncate":
            path.write_bytes(path.read_bytes()[:1000])
        else:
            arrays = rundir.read_npz(path)
            del arrays["state.diverged_at"]
            path.write_bytes(rundir.npz_bytes(arrays))
        before = path.read_bytes()
        assert train_main(["--resume", str(broken), "--quiet"]) == 2
        assert message in _one_line(capsys)
        assert path.read_bytes() == before


@pytest.mark.slow
def test_divergence_drop_freezes_runs_and_evaluation_skips_them(tmp_path, capsys):
    out = tmp_path / "run"
    argv = [*DIVERGING, "run.on_divergence=drop", "--quiet", "--out", str(out)]
    assert train_main(argv) == 2  # every run diverged: nothing usable, say so
    assert "every run" in _one_line(capsys)
    summary = json.loads((out / rundir.SUMMARY).read_text())
    assert {(d["strategy"], d["seed"]) for d in summary["diverged"]} == {
        (s, n) for s in ("ebe", "epsilon_greedy") for n in (0, 1)
    }
    assert all(d["step"] == 65 for d in summary["diverged"])
    params = rundir.read_npz(out / rundir.PARAMS)
    assert all(np.isfinite(v).all() for v in params.values())  # frozen, last finite
    assert evaluate_main([str(out)]) == 2
    assert "every run diverged" in capsys.readouterr().err


def test_bad_divergence_setting_is_refused(capsys, tmp_path):
    assert (
        train_main(["configs/smoke.yaml", "run.on_divergence=ignore", "--out", str(tmp_path)]) == 2
    )
    assert "run.on_divergence must be stop or drop" in _one_line(capsys)


def test_policy_with_non_finite_weights_is_refused():
    k = np.zeros((26, 5))
    k[3, 2] = np.nan
    meta = {
        "n_beams": 24,
        "obstacle_obs": False,
        "min_range": 0.12,
        "max_range": 3.5,
        "omegas": [-1.5, -0.75, 0.0, 0.75, 1.5],
        "linear_velocity": 0.15,
    }
    with pytest.raises(PolicyError, match="non-finite"):
        Policy([(k, np.zeros(5))], meta)
    Policy([(np.zeros((26, 5)), np.zeros(5))], meta)  # the same, finite, loads


@pytest.mark.parametrize(
    "outline",
    [
        "[[0, 0], [1e30, 0], [1e30, 1e30], [0, 1e30], [0, 0]]",
        "[[-2000, -1], [2000, -1], [2000, 1], [-2000, 1], [-2000, -1]]",
    ],
)
def test_absurd_maze_coordinates_are_one_line(tmp_path, outline):
    f = tmp_path / "big.yaml"
    f.write_text(f"outline: {outline}\n")
    with pytest.raises(MazeError, match="1 km") as e:
        load_maze_file(str(f))
    assert "\n" not in str(e.value)


def test_an_output_that_cannot_be_created_is_one_line(tmp_path, capsys):
    assert train_main(["configs/smoke.yaml", "--out", "/proc/jaxnav/run"]) == 2
    line = _one_line(capsys)
    assert "/proc/jaxnav/run" in line
    assert not (tmp_path / "run").exists()


def test_resume_removes_the_temporary_files_of_a_killed_writer(tmp_path):
    (tmp_path / "checkpoints").mkdir()
    stale = [tmp_path / ".metrics.csv.tmp123", tmp_path / "checkpoints" / ".last.npz.tmp9"]
    for p in stale:
        p.write_bytes(b"half")
    keep = tmp_path / "metrics.csv"
    keep.write_text("strategy\n")
    assert rundir.remove_stale_temps(tmp_path) == 2
    assert not any(p.exists() for p in stale) and keep.exists()


@pytest.mark.slow
def test_out_into_a_finished_run_needs_overwrite_and_never_a_busy_one(tmp_path, capsys):
    out = tmp_path / "run"
    tiny = ["configs/smoke.yaml", "seeds=1", "episodes=2", "env.max_steps=20", "dqn.batch_size=16"]
    assert train_main([*tiny, "--quiet", "--out", str(out)]) == 0
    capsys.readouterr()
    before = (out / rundir.PARAMS).read_bytes()
    assert train_main([*tiny, "seed=5", "--quiet", "--out", str(out)]) == 2
    assert "--overwrite replaces it" in _one_line(capsys)
    assert (out / rundir.PARAMS).read_bytes() == before
    with rundir.Lock(out):  # another command is using it
        assert train_main([*tiny, "seed=5", "--quiet", "--out", str(out), "--overwrite"]) == 2
        _one_line(capsys)
    assert (out / rundir.PARAMS).read_bytes() == before
    (out / "notes.txt").write_text("mine")
    assert train_main([*tiny, "seed=5", "--quiet", "--out", str(out), "--overwrite"]) == 2
    assert "'notes.txt'" in _one_line(capsys)
    (out / "notes.txt").unlink()
    assert train_main([*tiny, "seed=5", "--quiet", "--out", str(out), "--overwrite"]) == 0
    assert "seed: 5" in (out / rundir.CONFIG).read_text()
    assert (out / rundir.PARAMS).read_bytes() != before


@pytest.mark.slow
@pytest.mark.parametrize("failing", ["checkpoint", "metrics.csv"])
def test_a_full_disk_mid_training_loses_nothing(tmp_path, capsys, monkeypatch, failing):
    """A write fails part-way (ENOSPC) in the third chunk: one line, exit 2, the logs
    and the checkpoint exactly as the second chunk left them; a resume then ends
    exactly as an uninterrupted run."""
    tiny = ["configs/smoke.yaml", "seeds=1", "episodes=4", "env.max_steps=30"]
    tiny += ["run.chunk_steps=30", "run.chunk_s=0", "run.checkpoint_s=0", "--quiet"]
    ref, out = tmp_path / "ref", tmp_path / "run"
    assert train_main([*tiny, "--out", str(ref)]) == 0

    saved = []  # the files after each checkpoint written
    full = OSError(28, "No space left on device")
    real_atomic, real_append = rundir.atomic_write, rundir.CsvLog.append

    def atomic(path, write):
        if path.name == "last.npz" and failing == "checkpoint" and len(saved) == 2:

            def half_then_full(f, whole=write):  # what a full disk does to the temporary file
                whole(f)
                f.truncate(f.tell() // 2)
                raise full

            write = half_then_full
        real_atomic(path, write)
        if path.name == "last.npz":
            saved.append(_files(out))

    def append(self, rows):
        if self.path.name == "metrics.csv" and failing == "metrics.csv" and len(saved) == 2:
            with open(self.path, "a") as f:
                f.write("ebe,0,9,12")  # half a row, then the disk is full
            raise full
        return real_append(self, rows)

    monkeypatch.setattr(rundir, "atomic_write", atomic)
    monkeypatch.setattr(rundir.CsvLog, "append", append)
    assert train_main([*tiny, "--out", str(out)]) == 2
    assert "No space left on device" in _one_line(capsys)
    monkeypatch.undo()

    assert len(saved) == 2 and _files(out) == saved[-1]
    assert not (out / rundir.PARAMS).exists()
    assert train_main(["--resume", str(out), "--quiet"]) == 0
    for name in (rundir.METRICS, rundir.EXPLORE, rundir.PARAMS):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


def _files(run_dir) -> dict[str, bytes]:
    names = (rundir.METRICS, rundir.EXPLORE, rundir.CHECKPOINT)
    return {name: (run_dir / name).read_bytes() for name in names}


@pytest.mark.slow
def test_resume_of_a_run_with_only_its_config_starts_it(tmp_path, capsys):
    """A directory holding only config.yaml (and a cut metrics.csv): killed before its
    first checkpoint, so --resume trains it from the start."""
    tiny = [
        "configs/smoke.yaml",
        "seeds=1",
        "episodes=2",
        "env.max_steps=20",
        "dqn.batch_size=16",
        "--quiet",
    ]
    ref, out = tmp_path / "ref", tmp_path / "run"
    assert train_main([*tiny, "--out", str(ref)]) == 0
    out.mkdir()
    shutil.copy(ref / rundir.CONFIG, out / rundir.CONFIG)
    (out / rundir.METRICS).write_bytes((ref / rundir.METRICS).read_bytes()[:70])
    assert train_main(["--resume", str(out), "--quiet"]) == 0
    for name in (rundir.METRICS, rundir.EXPLORE, rundir.PARAMS):
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name
