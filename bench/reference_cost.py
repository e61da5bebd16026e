"""What the reference drivers (the oracle and DWA) cost in a test, and what their cache
saves: whole commands, each in its own process, taking turns.

1. **their share of a test** (``--only share``): on square4 and stage4 at 16 seeds
   (``drive_square4`` and ``drive_stage4`` trained for a few thousand steps: a test's
   cost does not depend on how well the policies drive, every test episode is played
   to its step limit), ``python -m jaxnav evaluate RUN`` timed whole three ways in
   turn: A ``--no-baselines`` (the policies alone), B with the reference drivers and
   their cache emptied first (cold: they are driven), C with the cache B filled (warm:
   their rows are read). The reference rows' share of a test is (B - A) / B cold and
   (C - A) / C warm. A first round fills the compilation cache and is not counted
   (its figures are printed: what a first test on a new machine costs).
2. **the quick reproduction** (``--only reproduce``): ``python -m jaxnav reproduce
   --quick`` as it is now (the reference drivers left out) and with ``--baselines``
   (their cache emptied first), in turn; with ``--old DIR`` a checkout of an older
   commit's code (``git archive COMMIT | tar -x -C DIR``) takes its turn too, its own
   ``reproduce --quick``.
3. **where a driver's test spends its time** (``--only profile``): the test rollout of
   the policies, the oracle and DWA on one world, compiled without the compilation
   cache (compile seconds), run once untimed, then timed and traced with
   ``jax.profiler``: the operations' own time summed per named scope of the rollout
   (``act``, ``env_step``) and of the oracle's step (``oracle_fields``: its raster
   fields where the goal or maze changed; ``oracle_exact``: the step about to be
   driven, checked exactly; ``oracle_simulate``: the tree of held actions on the
   raster; ``oracle_score``: the plans' ways, waits and choice), and the collectives
   between devices apart.

    python bench/reference_cost.py                     # 1 and 2: about an hour on 2 cores
    python bench/reference_cost.py --only share --rounds 1
    python bench/reference_cost.py --only reproduce --old /tmp/jaxnav-3059777
    python bench/reference_cost.py --only profile --world drive_stage4 --episodes 1

Every measurement keeps a compilation cache and a reference cache of its own (in a
temporary folder), so nothing the user has cached is read or changed. Medians over
``--rounds``; on a shared machine compare the figures of one run only.
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import ROOT, child_env, machine

WORLDS = ("drive_square4", "drive_stage4")
TRAIN = ("total_steps=8192", "run.chunk_steps=8192", "run.eval_every=0")


def _run(cmd: list[str], env: dict, cwd: Path = ROOT) -> float:
    """Seconds the whole command took (its failure: RuntimeError with its last line)."""
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["?"])[-1]
        raise RuntimeError(f"{' '.join(cmd[1:])} failed: {last}")
    return wall


def _env(tmp: Path, old: Path | None = None) -> dict:
    """A child's environment: its own compilation and reference caches; ``old``: the
    code of an older checkout instead of this one."""
    env = child_env({"JAXNAV_CACHE": str(tmp / "jax"), "JAXNAV_REFERENCE_CACHE": str(tmp / "ref")})
    if old is not None:
        env["PYTHONPATH"] = str(old)
    return env


def share(worlds: list[str], rounds: int, log) -> list[dict]:
    """Part 1: per world, the policies' test alone, with the reference drivers cold and
    warm; medians over rounds after one that fills the compilation cache."""
    out = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        env = _env(tmp)
        for world in worlds:
            run = tmp / world
            log(f"$ python -m jaxnav train {world} {' '.join(TRAIN)} (not timed)")
            _run([sys.executable, "-m", "jaxnav", "train", world, *TRAIN, "--out", str(run)], env)
            ev = [sys.executable, "-m", "jaxnav", "evaluate", str(run), "--overwrite", "--out"]
            times: dict[str, list[float]] = collections.defaultdict(list)
            for r in range(rounds + 1):
                a = _run([*ev, str(tmp / "a"), "--no-baselines"], env)
                shutil.rmtree(tmp / "ref", ignore_errors=True)
                b = _run([*ev, str(tmp / "b")], env)
                c = _run([*ev, str(tmp / "c")], env)
                what = "fills the compilation cache, not counted" if r == 0 else f"round {r}"
                log(f"  {world} ({what}): A {a:.1f} s, B cold {b:.1f} s, C warm {c:.1f} s")
                for k, v in zip("abc", (a, b, c)):
                    times[k if r else k + "0"].append(v)
            a, b, c = (statistics.median(times[k]) for k in "abc")
            out.append(
                {
                    "world": world,
                    "policies_s": a,
                    "cold_s": b,
                    "warm_s": c,
                    "share_cold": (b - a) / b,
                    "share_warm": (c - a) / c,
                    "first": [times[k + "0"][0] for k in "abc"],
                }
            )
    return out


def reproduce(rounds: int, old: Path | None, log) -> dict[str, list[float]]:
    """Part 2: ``reproduce --quick`` as it is, with ``--baselines`` (reference cache
    emptied), and an older checkout's, in turn; after one round that is not counted."""
    arms = {"now": [], "now --baselines": []}
    if old is not None:
        arms["old"] = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for r in range(rounds + 1):
            for arm in arms:
                code = old if arm == "old" else None
                env = _env(tmp / ("old" if code else "now"), code)
                cmd = [sys.executable, "-m", "jaxnav", "reproduce", "--quick", "--quiet"]
                cmd += ["--baselines"] if arm.endswith("--baselines") else []
                out = tmp / f"out-{arm.replace(' ', '')}-{r}"
                shutil.rmtree(tmp / "now" / "ref", ignore_errors=True)
                wall = _run([*cmd, "--out", str(out)], env, cwd=code or ROOT)
                log(
                    f"  reproduce --quick, {arm} ({'not counted' if r == 0 else f'round {r}'}): "
                    f"{wall:.1f} s"
                )
                if r:
                    arms[arm].append(wall)
                shutil.rmtree(out, ignore_errors=True)
    return arms


def profile(world: str, episodes: int, log) -> None:
    """Part 3 (in this process): where the policies', the oracle's and DWA's test time
    goes on one world."""
    import os

    os.environ["JAXNAV_CACHE"] = "off"  # every program compiled here, and timed
    sys.path.insert(0, str(ROOT))  # this checkout's jaxnav, as the commands' children get
    from jaxnav.core.startup import before_jax

    before_jax()
    import jax
    import numpy as np
    from profile_train import _op_sources, _self_times

    from jaxnav.agent.sharding import RunSharding
    from jaxnav.experiments.baselines import in_place_of
    from jaxnav.experiments.evaluation import load_run, test_setup
    from jaxnav.experiments.rollout import eval_keys, make_rollout, padded_mazes

    with tempfile.TemporaryDirectory() as d:
        run_dir = Path(d) / world
        env = child_env({"JAXNAV_CACHE": str(Path(d) / "jax")})
        _run([sys.executable, "-m", "jaxnav", "train", world, *TRAIN, "--out", str(run_dir)], env)
        run = load_run(run_dir)
    names, _ = test_setup(run, None, None, run.config.run.test_mazes)
    mazes = padded_mazes(names)
    log(
        f"# {world}: {len(run.policies.labels)} policies, {episodes} test episodes of "
        f"{int(run.policies.env_params.max_steps)} steps on {names[0]}; {machine()}"
    )
    for who in ("policies", "oracle", "dwa"):
        drivers = run.policies if who == "policies" else in_place_of(who, run.policies, mazes)
        shard = RunSharding(len(drivers.labels))
        steps = int(drivers.env_params.max_steps)
        rollout = make_rollout(drivers.env, drivers.network, episodes, steps, False, None, True)
        batch = jax.vmap(rollout, in_axes=(0, 0, 0, 0, None))

        def per_run(runs, env_params, batch=batch):
            return batch(*runs, env_params)

        # compiled as the tests compile it (jaxnav.experiments.rollout._compiled_rollout):
        # each device plays its own runs as one batch
        fn = jax.jit(RunSharding(1).per_device(per_run, 2))
        runs = (
            shard.put(jax.tree.map(np.asarray, drivers.params)),
            shard.put(np.asarray(eval_keys(drivers.labels))),
            shard.put(np.asarray(drivers.strategy, np.int32)),
            shard.put(jax.tree.map(np.asarray, drivers.hyper)),
        )
        args = (runs, drivers.env_params.replace(maze=mazes[0]))
        t0 = time.perf_counter()
        compiled = fn.lower(*args).compile()
        compile_s = time.perf_counter() - t0
        sources = _op_sources(compiled.as_text())
        jax.block_until_ready(compiled(*args))
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(*args))
        run_s = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as tdir:
            with jax.profiler.trace(tdir, create_perfetto_trace=True):
                jax.block_until_ready(compiled(*args))
            (path,) = glob.glob(f"{tdir}/**/*.trace.json.gz", recursive=True)
            with gzip.open(path) as f:
                events = json.load(f)["traceEvents"]
        per_op = _self_times([e for e in events if e.get("ph") == "X" and e.get("name") in sources])
        total = sum(per_op.values()) or 1.0
        groups: collections.Counter = collections.Counter()
        for name, us in per_op.items():
            scopes = re.findall(r"/(oracle_\w+|act|env_step)(?=/)", sources.get(name, "") + "/")
            part = scopes[-1] if scopes else "rest of the rollout (keys, records, loop)"
            if re.match(r"all-|collective|reduce-scatter", name):
                part += ", collectives between devices"
            groups[part] += us
        log(
            f"\n{who}: compile {compile_s:.1f} s (no compilation cache), run {run_s:.2f} s "
            f"({1e3 * run_s / (episodes * steps):.2f} ms per lockstep step)"
        )
        log("| part | share of operation time |\n|---|--:|")
        for part, us in groups.most_common():
            log(f"| {part} | {100 * us / total:.1f}% |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=("share", "reproduce", "profile"))
    ap.add_argument("--rounds", type=int, default=2, help="counted rounds (medians)")
    ap.add_argument("--worlds", nargs="+", default=list(WORLDS), help="configs for part 1")
    ap.add_argument("--old", type=Path, help="an older checkout's code for part 2")
    ap.add_argument("--world", default="drive_square4", help="the config part 3 profiles")
    ap.add_argument("--episodes", type=int, default=2, help="test episodes part 3 profiles")
    args = ap.parse_args(argv)

    def log(line: str) -> None:
        print(line, flush=True)

    if args.only == "profile":
        profile(args.world, args.episodes, log)
        return 0
    log(f"# bench/reference_cost.py, {time.strftime('%Y-%m-%d %H:%M')}; {machine()}")
    if args.only in (None, "share"):
        log("\n## The reference drivers' share of a test (16 seeds, jaxnav evaluate, whole)")
        rows = share(args.worlds, args.rounds, log)
        log(
            "\n| world | policies alone | with the drivers, cold | their share | warm (cached) "
            "| their share | first test, empty compilation cache: alone, cold, warm |"
        )
        log("|---|--:|--:|--:|--:|--:|---|")
        for r in rows:
            first = ", ".join(f"{t:.0f} s" for t in r["first"])
            log(
                f"| {r['world']} | {r['policies_s']:.1f} s | {r['cold_s']:.1f} s | "
                f"{100 * r['share_cold']:.0f}% | {r['warm_s']:.1f} s | "
                f"{100 * r['share_warm']:.0f}% | {first} |"
            )
        log("\nTarget: the reference rows at most 20% of a test's time.")
    if args.only in (None, "reproduce"):
        log("\n## jaxnav reproduce --quick, whole, in turn")
        arms = reproduce(args.rounds, args.old, log)
        log("\n| code | median | runs |\n|---|--:|---|")
        for arm, walls in arms.items():
            label = f"{args.old} (older checkout)" if arm == "old" else f"this checkout, {arm}"
            runs = ", ".join(f"{w:.1f}" for w in walls)
            log(f"| {label} | {statistics.median(walls):.1f} s | {runs} |")
        if "old" in arms:
            ratio = statistics.median(arms["now"]) / statistics.median(arms["old"])
            log(f"\nNow / older checkout: {ratio:.2f} (target: within 10%, at most 1.10).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
