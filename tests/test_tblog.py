"""TensorBoard curves while training: read back from the event files."""

import csv
import struct

import numpy as np
import pytest

from jaxnav.commands.train import main as train_main
from jaxnav.run.training import Run

tensorboardX = pytest.importorskip("tensorboardX", reason="optional extra 'tensorboard'")
from tensorboardX.proto import event_pb2  # noqa: E402

TINY = ["configs/smoke.yaml", "seeds=2", "episodes=6", "env.max_steps=100"]
TINY += ["run.chunk_steps=250", "run.chunk_s=0", "run.checkpoint_s=0"]  # chunks of 250
TINY += ["run.tensorboard=true", "--quiet"]


def events(run_dir):
    """Every Event of every event file under run_dir, in order (TFRecord framing: a
    length, its CRC, the Event, its CRC)."""
    for path in sorted(run_dir.glob("events.out.tfevents.*")):
        data, pos = path.read_bytes(), 0
        while pos < len(data):
            (n,) = struct.unpack("<Q", data[pos : pos + 8])
            yield event_pb2.Event.FromString(data[pos + 12 : pos + 12 + n])
            pos += 12 + n + 4


def _purges(event) -> bool:
    """A writer's start at a purge step: TensorBoard drops what came before at or above it."""
    return event.HasField("session_log") and event.session_log.status == 1  # START


def read_scalars(run_dir) -> dict[str, dict[int, float]]:
    """{tag: {step: value}} as TensorBoard shows them: later values override earlier
    ones, and a purge (a resume) drops what came before at or above its step."""
    out: dict[str, dict[int, float]] = {}
    for event in events(run_dir):
        if _purges(event):
            for steps in out.values():
                for s in [s for s in steps if s >= event.step]:
                    del steps[s]
        for v in event.summary.value:
            out.setdefault(v.tag, {})[event.step] = v.simple_value
    return out


def purge_steps(run_dir) -> list[int]:
    """The steps at which a writer told TensorBoard to drop what came before (resumes)."""
    return [event.step for event in events(run_dir) if _purges(event)]


@pytest.mark.slow
def test_episode_and_step_curves_are_the_runs_own_numbers(tmp_path):
    out = tmp_path / "run"
    assert train_main([*TINY, "--out", str(out)]) == 0
    episodes = read_scalars(out / "tensorboard" / "episodes")
    steps = read_scalars(out / "tensorboard" / "steps")
    rows = list(csv.DictReader((out / "metrics.csv").open()))
    for strategy in ("ebe", "epsilon_greedy"):
        for name in ("return", "goals", "length", "collided", "explore"):
            got = episodes[f"{strategy}/{name}"]
            assert sorted(got) == list(range(6))
            for e, value in got.items():
                want = np.mean(
                    [
                        float(r[name])
                        for r in rows
                        if r["strategy"] == strategy and r["episode"] == str(e)
                    ]
                )
                assert value == pytest.approx(want, rel=1e-5), (strategy, name, e)
        loss, max_q = steps[f"{strategy}/loss"], steps[f"{strategy}/max_q"]
        # blocks of 100 steps within each 250-step chunk; learning starts at step 64
        assert sorted(loss)[:4] == [0, 100, 200, 250]
        assert all(np.isfinite(v) and v >= 0 for v in loss.values())
        assert set(max_q) >= set(loss)


@pytest.mark.slow
def test_a_resumed_run_purges_what_came_after_its_checkpoint(tmp_path, monkeypatch):
    ref, out = tmp_path / "ref", tmp_path / "run"
    assert train_main([*TINY, "--out", str(ref)]) == 0
    saves, real_save = [], Run.save

    def killed_at_second_checkpoint(self, *args, **kwargs):
        """The second chunk's curves are written; the process dies before its checkpoint."""
        saves.append(1)
        if len(saves) == 2:
            raise KeyboardInterrupt
        return real_save(self, *args, **kwargs)

    monkeypatch.setattr(Run, "save", killed_at_second_checkpoint)
    assert train_main([*TINY, "--out", str(out)]) == 130
    monkeypatch.undo()
    assert read_scalars(out / "tensorboard" / "steps") != read_scalars(
        ref / "tensorboard" / "steps"
    )
    assert train_main(["--resume", str(out), "--quiet"]) == 0
    for part in ("episodes", "steps"):
        assert read_scalars(out / "tensorboard" / part) == read_scalars(ref / "tensorboard" / part)
    # TensorBoard is told to drop the killed process's curves past the checkpoint
    assert purge_steps(out / "tensorboard" / "steps") == [250]
    assert purge_steps(out / "tensorboard" / "episodes") == [0]


@pytest.mark.slow
def test_a_swept_run_has_one_curve_per_arm_averaged_over_its_seeds(tmp_path):
    out = tmp_path / "run"
    argv = [*TINY, "strategies=[ebe]", "sweep.exploration.ebe_temperature=[0.1,1]"]
    assert train_main([*argv, "--out", str(out)]) == 0
    episodes = read_scalars(out / "tensorboard" / "episodes")
    rows = list(csv.DictReader((out / "metrics.csv").open()))
    for temperature in ("0.1", "1"):
        got = episodes[f"ebe/ebe_temperature_{temperature}/return"]
        assert sorted(got) == list(range(6))
        mine = [r for r in rows if r["exploration.ebe_temperature"] == temperature]
        want = np.mean([float(r["return"]) for r in mine if r["episode"] == "3"])
        assert got[3] == pytest.approx(want, rel=1e-5)


def test_evaluation_curves_are_the_means_of_eval_csv_over_seeds(tmp_path):
    from jaxnav.run.greedy import EVAL_COLUMNS
    from jaxnav.run.tblog import TensorBoardLog
    from jaxnav.run.training import METRIC_COLUMNS

    labels = [("ebe", 0), ("ebe", 1), ("epsilon_greedy", 0), ("epsilon_greedy", 1)]
    rows = [  # strategy, seed, env_step, wall_s, return, goals, collided, attempts, ...
        ("ebe", 0, 300, "1.5", "10", "1", "0", 5, 2, "0.4"),
        ("ebe", 1, 300, "1.5", "20", "3", "0", 5, 4, "0.8"),
        ("epsilon_greedy", 0, 280, "1.5", "-5", "0", "1", 3, 0, "0"),
        ("epsilon_greedy", 1, 300, "1.5", "5", "2", "0", 4, 2, "0.5"),
    ]
    tb = TensorBoardLog(tmp_path, labels, METRIC_COLUMNS, eval_columns=EVAL_COLUMNS)
    tb.add_evals(rows)
    tb.close()
    got = read_scalars(tmp_path / "tensorboard" / "eval")
    assert got["ebe/return"] == {300: 15.0} and got["ebe/goals"] == {300: 2.0}
    assert got["ebe/success"][300] == pytest.approx(0.6)
    assert got["epsilon_greedy/success"][300] == pytest.approx(0.25)  # the lockstep step
    # resumed from a checkpoint at step 300: its evaluation stays, later ones go
    TensorBoardLog(tmp_path, labels, METRIC_COLUMNS, True, 300, EVAL_COLUMNS).close()
    assert purge_steps(tmp_path / "tensorboard" / "eval") == [301]


def test_a_run_without_evaluation_writes_no_evaluation_curves(tmp_path):
    from jaxnav.run.tblog import TensorBoardLog
    from jaxnav.run.training import METRIC_COLUMNS

    TensorBoardLog(tmp_path, [("ebe", 0)], METRIC_COLUMNS).close()
    assert not (tmp_path / "tensorboard" / "eval").exists()


def test_a_run_with_tensorboard_says_where_its_curves_are(tmp_path, capsys):
    from jaxnav.core import rundir
    from jaxnav.core.config import load_config

    cfg = load_config("smoke", ["seeds=1", "episodes=1", "run.tensorboard=true"])
    out = tmp_path / "run"
    rundir.create(out)
    run = Run(cfg, out, quiet=False)
    run._tensorboard(run.fresh_state()).close()
    err = capsys.readouterr().err
    assert f"tensorboard --logdir {out / 'tensorboard'}" in err
