"""The run directory: atomic writes, appended logs cut back on resume, one writer, checks."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from jaxnav.core import cli, rundir
from jaxnav.core.errors import ConfigError, JaxnavError, MazeError, PolicyError, RunError

ROOT = Path(__file__).resolve().parent.parent


def test_atomic_write_replaces_the_whole_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "a.txt"
    rundir.atomic_write_text(path, "old")
    rundir.atomic_write_text(path, "new")
    assert path.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_a_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    path = tmp_path / "a.txt"
    rundir.atomic_write_text(path, "good")

    def broken_fsync(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(OSError):
        rundir.atomic_write_text(path, "half")
    assert path.read_text() == "good"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_csv_log_appends_rows_under_one_header_and_truncates_to_a_checkpoint(tmp_path):
    log = rundir.CsvLog(tmp_path / "m.csv", ("a", "b"))
    size1 = log.append([(1, 2)])
    log.append([(3, 4), (5, 6)])
    assert log.path.read_text() == "a,b\n1,2\n3,4\n5,6\n"
    log.truncate(size1)  # the rows after the checkpoint go
    assert log.read() == [{"a": "1", "b": "2"}]
    with pytest.raises(RunError, match="shorter than its checkpoint"):
        log.truncate(size1 + 100)


def test_npz_round_trip_and_pickles_are_refused(tmp_path):
    path = tmp_path / "x.npz"
    rundir.atomic_write_bytes(path, rundir.npz_bytes({"a": np.arange(3)}))
    np.testing.assert_array_equal(rundir.read_npz(path)["a"], np.arange(3))
    np.savez(tmp_path / "p.npz", a=np.asarray([{"evil": 1}], dtype=object))
    with pytest.raises(RunError, match="cannot be read"):
        rundir.read_npz(tmp_path / "p.npz")
    with pytest.raises(RunError, match="does not exist"):
        rundir.read_npz(tmp_path / "missing.npz")


def test_params_are_found_by_strategy_and_seed(tmp_path):
    path = tmp_path / "params.npz"
    arrays = {
        rundir.params_key("ebe", 3, "params/Dense_0/kernel"): np.ones((2, 2)),
        rundir.params_key("ebe", 3, "params/Dense_0/bias"): np.zeros(2),
        rundir.params_key("epsilon_greedy", 4, "params/Dense_0/bias"): np.zeros(2),
    }
    rundir.atomic_write_bytes(path, rundir.npz_bytes(arrays))
    assert rundir.runs_in(path) == {"ebe": [3], "epsilon_greedy": [4]}
    tree = rundir.load_params(path, "ebe", 3)
    assert set(tree["params"]["Dense_0"]) == {"kernel", "bias"}
    with pytest.raises(RunError, match="no parameters for ebe seed 4"):
        rundir.load_params(path, "ebe", 4)


def test_the_checks_of_a_run_directory(tmp_path):
    with pytest.raises(RunError, match="does not exist"):
        rundir.existing(tmp_path / "nope")
    with pytest.raises(RunError, match="not a run directory"):
        rundir.existing(tmp_path)
    (tmp_path / rundir.CONFIG).write_text("seeds: 1\n")
    assert rundir.existing(tmp_path) == tmp_path
    with pytest.raises(RunError, match="training has not finished"):
        rundir.existing(tmp_path, finished=True)
    with pytest.raises(RunError, match="not empty"):
        rundir.create(tmp_path)
    (tmp_path / "file").write_text("x")
    with pytest.raises(RunError, match="not a directory"):
        rundir.create(tmp_path / "file")
    assert rundir.create(tmp_path / "new").is_dir()


def test_a_run_directory_has_one_writer_and_a_killed_one_leaves_no_lock(tmp_path):
    with rundir.Lock(tmp_path):
        with pytest.raises(RunError, match="in use by another process"):
            with rundir.Lock(tmp_path):
                pass
    # A process that holds the lock and dies by SIGKILL: the lock goes with it.
    code = (
        "import os, signal, sys; from jaxnav.core import rundir\n"
        f"rundir.Lock({str(tmp_path)!r}).__enter__()\n"
        "print('locked', flush=True); os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert proc.stdout == "locked\n"
    with rundir.Lock(tmp_path):
        pass


@pytest.mark.parametrize("error", [ConfigError, MazeError, RunError, PolicyError, JaxnavError])
def test_every_error_is_one_line_and_exit_2(error, capsys):
    def work():
        raise error("what is wrong, in one line")

    assert cli.run("python -m jaxnav.x", work) == 2
    assert capsys.readouterr().err == "jaxnav.x: error: what is wrong, in one line\n"


def test_file_system_errors_and_interrupts(tmp_path, capsys):
    def missing():
        open(tmp_path / "missing.txt")

    assert cli.run("jaxnav.x", missing) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No such file or directory" in err and "missing.txt" in err

    def interrupted():
        raise KeyboardInterrupt

    assert cli.run("jaxnav.x", interrupted, interrupted="stopped") == 130
    assert capsys.readouterr().err.strip() == "jaxnav.x: stopped"
    assert cli.run("jaxnav.x", lambda: None) == 0
