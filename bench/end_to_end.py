"""What a user waits for: whole commands, compilation included, beside the steady state.

In one run, one measurement after the other (never two at once):

1. **steady state**: training transitions/s at 64 runs, 24 beams, full-run replay
   capacity, compilation excluded (``bench/train_throughput.py``'s case);
2. **the whole command, cold**: ``jaxnav train configs/paper_no_obstacles.yaml
   seeds=32 episodes=E`` (64 runs) with an empty compilation cache, timed from launch
   to exit; its transitions/s (real env steps over the whole wall-clock) as a share
   of (1), its peak RSS (``wait4``), and from its ``summary.json`` the share of the
   steps computed in lockstep that were real steps;
3. **the same command again**, with the cache the first one filled; and how long
   after launch a second run starts training (``summary.json``'s ``startup_s``:
   imports, set-up, and the compiled program loaded from the cache), as the median
   of three one-episode runs after one that fills the cache for them;
4. **against Stable-Baselines3, whole processes**: ``jaxnav train`` with 16 seeds x 2
   strategies for E2 episodes (cold cache), against SB3's DQN
   (``bench/peers_sb3.py``'s model: same network, loss and hyperparameters) doing the
   same 32 runs the way SB3 does them on this machine: one one-thread process per
   core, each training its share of the runs one after another. Measured: each
   process (started at once) trains one run of as many transitions as our average
   run, timed whole (Python start, imports, the environment's compilation, model
   build) and inside ``learn``; SB3's time for the 32 runs is then, per process,
   its start-up once plus its share of runs at its measured time per run (the
   slowest process). Skipped when stable-baselines3 is not installed
   (bench/README.md);
5. without ``--quick``, ``jaxnav reproduce --seeds 32`` timed whole.

``--only sb3`` or ``--only reproduce`` runs step 4 (E2 = 100 by default) or step 5 alone.

    python bench/end_to_end.py --quick     # E = 30, E2 = 30, no reproduce: about 5 min
    python bench/end_to_end.py             # E = 500 (a full paper run), E2 = 100, reproduce
    python bench/end_to_end.py --only sb3  # step 4 alone, E2 = 100

With ``--quick`` the whole commands are short, so compilation weighs more in them
than in a full run, and the memory target is not judged: a short run has touched
few pages of its replay buffers, so its peak RSS says little about a full one.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import MARK, ROOT, child_env, cores, find_python, machine, ours_train

CONFIG = "configs/paper_no_obstacles.yaml"


def train_command(seeds: int, episodes: int, out: Path, cache: Path, log) -> dict:
    """The whole ``jaxnav train`` command: wall-clock, peak RSS and its summary.json."""
    cmd = [
        sys.executable,
        "-m",
        "jaxnav.commands.train",
        CONFIG,
        f"seeds={seeds}",
        f"episodes={episodes}",
        "--out",
        str(out),
        "--quiet",
    ]
    env = child_env({"JAXNAV_CACHE": str(cache)})
    log("$ " + " ".join(["python", *cmd[1:]]))
    # stderr to a file, not a pipe: wait4 (for the child's own peak RSS) reads nothing
    # while the child runs, and a full pipe would block it
    with tempfile.TemporaryFile() as errf:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=errf)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        errf.seek(0)
        err = errf.read().decode(errors="replace")
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(
            f"jaxnav.commands.train failed: {(err.strip().splitlines() or ['?'])[-1]}"
        )
    summary = json.loads((out / "summary.json").read_text())
    steps = summary["env_steps"]
    r = {
        "runs": 2 * seeds,
        "episodes": episodes,
        "wall_s": wall,
        "env_steps": steps,
        "transitions_per_s": steps / wall,
        "in_chunk_transitions_per_s": summary["steps_per_s"],
        "peak_rss_gb": usage.ru_maxrss / 2**20,
        "startup_s": summary["startup_s"],
        "compile_s": summary["compile_s"],
        "lockstep_useful": summary["lockstep_useful"],
    }
    log(
        f"    {wall:.1f} s whole, {steps:,} transitions ({r['transitions_per_s']:,.0f}/s; "
        f"{r['in_chunk_transitions_per_s']:,.0f}/s inside the chunks), training began at "
        f"{r['startup_s']:.1f} s (compile {r['compile_s']:.1f} s), peak RSS "
        f"{r['peak_rss_gb']:.2f} GB, {100 * r['lockstep_useful']:.0f}% of lockstep steps real"
    )
    return r


def sb3_whole(processes: int, runs: int, transitions: int, capacity: int, python: str, log) -> dict:
    """SB3's wall-clock for ``runs`` runs of ``transitions`` each, over ``processes``
    one-thread processes (see the module docstring): measured on one run per process,
    all processes at once."""
    code = (
        "import sys, time; sys.path.insert(0, {bench!r}); "
        "from peers_sb3 import make_sb3; import torch; torch.set_num_threads(1); "
        "from jaxnav.interop.gym import NavGymEnv; "
        "env = NavGymEnv('square4', n_beams=24); "
        "m = make_sb3(env, {cap}, 2000, {n}, seed=int(sys.argv[1])); "
        "t0 = time.perf_counter(); m.learn(total_timesteps={n}); "
        "print({mark!r} + str(time.perf_counter() - t0))"
    ).format(bench=str(ROOT / "bench"), cap=capacity, n=transitions, mark=MARK)
    log(f"$ {processes} x SB3 DQN whole processes, {transitions:,} transitions each, at once")
    t0 = time.perf_counter()
    procs = [
        subprocess.Popen(
            [python, "-c", code, str(i)],
            cwd=ROOT,
            env=child_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for i in range(processes)
    ]
    learn, whole = [], []
    for p in procs:
        out, err = p.communicate()
        whole.append(time.perf_counter() - t0)
        lines = [x for x in out.splitlines() if x.startswith(MARK)]
        if p.returncode != 0 or not lines:
            raise RuntimeError(f"SB3 process failed: {(err.strip().splitlines() or ['?'])[-1]}")
        learn.append(float(lines[-1][len(MARK) :]))
    share = -(-runs // processes)  # runs per process
    wall = max(w - t + share * t for w, t in zip(whole, learn))
    r = {
        "processes": processes,
        "runs": runs,
        "transitions_per_run": transitions,
        "startup_s": [w - t for w, t in zip(whole, learn)],
        "learn_s": learn,
        "wall_s": wall,
        "transitions_per_s": runs * transitions / wall,
    }
    log(
        f"    start-up {', '.join(f'{x:.1f}' for x in r['startup_s'])} s, one run "
        f"{', '.join(f'{x:.1f}' for x in learn)} s: {runs} runs take {wall:.0f} s "
        f"({r['transitions_per_s']:,.0f} transitions/s)"
    )
    return r


def reproduce_whole(seeds: int, out: Path, cache: Path, log) -> dict:
    cmd = [
        sys.executable,
        "-m",
        "jaxnav.commands.reproduce",
        "--seeds",
        str(seeds),
        "--out",
        str(out),
    ]
    cmd.append("--quiet")
    env = child_env({"JAXNAV_CACHE": str(cache)})
    log("$ " + " ".join(["python", *cmd[1:]]))
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"reproduce failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
    log(f"    {wall / 60:.1f} min")
    return {"seeds": seeds, "wall_s": wall}


def measure(
    quick: bool, episodes: int | None = None, sb3_episodes: int | None = None, log=print
) -> dict:
    episodes = episodes or (30 if quick else 500)
    sb3_episodes = sb3_episodes or (30 if quick else 100)
    steps, reps = (1000, 2) if quick else (2000, 3)
    res: dict = {"quick": quick, "machine": machine()}
    log("$ python bench/train_throughput.py --case 64,24 (64 runs, capacity 250,000)")
    steady = ours_train(64, 24, steps, reps, 250_000)
    res["steady"] = {k: steady[k] for k in ("transitions_per_s", "compile_s", "peak_rss_mb")}
    log(f"    {steady['transitions_per_s']:,.0f} transitions/s")
    with tempfile.TemporaryDirectory(prefix="jaxnav-e2e-") as d:
        d = Path(d)
        res["cold"] = train_command(32, episodes, d / "cold", d / "cache", log)
        res["warm"] = train_command(32, episodes, d / "warm", d / "cache", log)
        res["whole_over_steady"] = res["cold"]["transitions_per_s"] / steady["transitions_per_s"]
        starts = [
            train_command(32, 1, d / f"start{i}", d / "cache", log)["startup_s"] for i in range(4)
        ]
        res["second_start_s"] = statistics.median(starts[1:])
        res |= against_sb3(sb3_episodes, d, log)
        if not quick:
            res["reproduce"] = reproduce_whole(32, d / "reproduce", d / "cache", log)
    return res


def against_sb3(episodes: int, d: Path, log) -> dict:
    """Step 4: ``jaxnav train`` with 16 seeds x 2 strategies for ``episodes`` episodes
    (cold cache) against SB3's whole processes; {} when SB3 is not installed."""
    sb3_py = find_python("stable_baselines3")
    if not sb3_py:
        log("SB3 skipped: stable-baselines3 is not installed (bench/README.md)")
        return {}
    ours = train_command(16, episodes, d / "vs_sb3", d / "cache_sb3", log)
    per_run = ours["env_steps"] // ours["runs"]
    sb3 = sb3_whole(cores(), ours["runs"], per_run, 250_000, sb3_py, log)
    ratio = sb3["wall_s"] / ours["wall_s"]
    log(
        f"    ours {ours['wall_s']:.1f} s ({100 * ours['lockstep_useful']:.0f}% of lockstep "
        f"steps real), SB3 {sb3['wall_s']:.1f} s: {ratio:.1f}x"
    )
    return {"sb3": {"ours": ours, "sb3": sb3}, "sb3_ratio": ratio}


def only(part: str, sb3_episodes: int | None, log) -> dict:
    """One step alone: ``sb3`` (step 4, E2 = 100 unless given) or ``reproduce`` (step 5)."""
    with tempfile.TemporaryDirectory(prefix="jaxnav-e2e-") as d:
        d = Path(d)
        if part == "sb3":
            return against_sb3(sb3_episodes or 100, d, log)
        return {"reproduce": reproduce_whole(32, d / "reproduce", d / "cache", log)}


def targets(res: dict) -> list[tuple[str, str, str, str]]:
    """(target, measured, met, how) rows; a target not measured says so."""
    rows = []

    def add(target, measured, met, how):
        rows.append((target, measured, "yes" if met else "no" if met is not None else "—", how))

    rep = res.get("reproduce")
    add(
        "`reproduce --seeds 32` in at most 10 min",
        f"{rep['wall_s'] / 60:.1f} min" if rep else "not run with --quick",
        rep["wall_s"] <= 600 if rep else None,
        "whole command",
    )
    cold, steady = res["cold"], res["steady"]["transitions_per_s"]
    add(
        "whole `jaxnav.commands.train` at 64 runs >= 90% of steady state",
        f"{100 * res['whole_over_steady']:.0f}% ({cold['transitions_per_s']:,.0f} of "
        f"{steady:,.0f}/s; {cold['episodes']} episodes; "
        f"{100 * cold['lockstep_useful']:.0f}% of lockstep steps real)",
        res["whole_over_steady"] >= 0.9,
        "cold cache, compilation included",
    )
    add(
        "steady state, 64 runs, 24 beams >= 35,000 transitions/s",
        f"{steady:,.0f}",
        steady >= 35_000,
        "compilation excluded",
    )
    if "sb3_ratio" in res:
        s = res["sb3"]
        add(
            ">= 30x SB3 end to end (32 runs; SB3 one process per core)",
            f"{res['sb3_ratio']:.1f}x ({s['ours']['wall_s']:.0f} s against SB3's "
            f"{s['sb3']['wall_s']:.0f} s)",
            res["sb3_ratio"] >= 30,
            f"whole processes, {s['ours']['episodes']} episodes",
        )
    else:
        add(">= 30x SB3 end to end", "SB3 not installed", None, "")
    add(
        "a second run starts training within 3 s",
        f"{res['second_start_s']:.1f} s (first run, cold cache: {cold['startup_s']:.1f} s)",
        res["second_start_s"] <= 3,
        "launch to first chunk, warm cache; median of 3, 64 runs",
    )
    full = cold["episodes"] >= 500  # a short run has not touched most replay pages
    add(
        "peak memory, 64 runs of a full paper run, 24 beams < 4 GB",
        f"{cold['peak_rss_gb']:.2f} GB" if full else "needs the full run (without --quick)",
        cold["peak_rss_gb"] < 4 if full else None,
        "whole command, peak RSS",
    )
    return rows


def markdown(rows) -> str:
    lines = ["| target | measured | met | how |", "|---|---|---|---|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="short commands, no reproduce")
    ap.add_argument("--episodes", type=int, help="E: episodes of the 64-run commands")
    ap.add_argument("--sb3-episodes", type=int, help="E2: episodes of the comparison with SB3")
    ap.add_argument("--json", help="also write the figures here")
    ap.add_argument(
        "--only", choices=("sb3", "reproduce"), help="one step alone: 4 (SB3) or 5 (reproduce)"
    )
    args = ap.parse_args(argv)
    print(f"# end to end; {machine()}", flush=True)
    if args.only:
        res = only(args.only, args.sb3_episodes, log=lambda s: print(s, flush=True))
        if args.json:
            Path(args.json).write_text(json.dumps(res, indent=1) + "\n")
        return 0
    res = measure(args.quick, args.episodes, args.sb3_episodes, log=lambda s: print(s, flush=True))
    print()
    print(markdown(targets(res)))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
