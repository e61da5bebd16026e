"""Where a training step's time goes: a ``jax.profiler`` trace of training chunks,
summed per XLA operation and grouped by the part of the step it comes from.

    python bench/profile_train.py                 # 64 runs, 24 beams, 1000-step chunks
    python bench/profile_train.py --runs 32 --top 25
    python bench/profile_train.py --set env.generator=grid --set env.maze_bank=64  # any config key

Runs the paper config's chunk (EBE, full-run replay capacity) on one CPU device per
core, as ``jaxnav train`` does, compiles it, then traces ``--reps`` chunks and reads
the trace back (Perfetto JSON): every event on the XLA threads is an operation of the
compiled program (a fusion, a dot, a gather, a while loop, ...), named by XLA, and
an operation's time is its own, without the operations nested in it. The part of an
operation is the named scope of ``jaxnav.dqn``'s step that its ``op_name`` metadata
carries (keys, act, env_step, replay_add, learn, replay_sample), read from the
compiled HLO; "other" is the rest (masks, metrics, target sync, the loop). Shares
are of the summed operation time over all threads; the profiler's own overhead
weighs most on the smallest operations, so read them as a ranking, and the
wall-clock per step printed beside them.
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import re
import statistics
import sys
import tempfile
import time

from common import cores, device_env

GROUPS = (  # (part, regex on the operation's op_name), first match wins
    ("replay sample (the minibatch gather)", r"/replay_sample/"),
    ("learner: gradient step (forward, backward, RMSprop, checks)", r"/learn/"),
    ("act (Q of the observation, exploration)", r"/act/"),
    ("environment step (LiDAR, collision, reward, resets)", r"/env_step/"),
    ("replay add", r"/replay_add/"),
    ("random keys", r"/keys/"),
)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=64)
    ap.add_argument("--beams", type=int, default=24)
    ap.add_argument("--steps", type=int, default=1000, help="steps per traced chunk")
    ap.add_argument("--reps", type=int, default=2, help="traced chunks")
    ap.add_argument("--top", type=int, default=15, help="operations listed")
    ap.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="config overrides"
    )
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if not args.child:
        import subprocess

        cmd = [sys.executable, __file__, "--child", *(argv or sys.argv[1:])]
        return subprocess.run(cmd, env=device_env(cores())).returncode
    return profile(args)


def _op_sources(hlo_text: str) -> dict[str, str]:
    """HLO instruction name -> its op_name and source metadata."""
    out = {}
    for m in re.finditer(r"^\s*(?:ROOT )?%?([\w.\-]+) = .*?metadata=\{([^}]*)\}", hlo_text, re.M):
        out[m.group(1)] = m.group(2)
    return out


def _self_times(events: list[dict]) -> collections.Counter:
    """Microseconds per operation name, each event less the events nested in it on the
    same thread (a while loop's own time, not its body's)."""
    out: collections.Counter = collections.Counter()
    by_thread = collections.defaultdict(list)
    for e in events:
        by_thread[(e.get("pid"), e.get("tid"))].append(e)
    for evs in by_thread.values():
        evs.sort(key=lambda e: (e["ts"], -e.get("dur", 0.0)))
        stack: list[list] = []  # [end, name, child time]
        for e in evs:
            start, dur = e["ts"], e.get("dur", 0.0)
            while stack and stack[-1][0] <= start:
                end, name, child = stack.pop()
                out[name] -= child
            if stack:
                stack[-1][2] += dur
            out[e["name"]] += dur
            stack.append([start + dur, e["name"], 0.0])
        for _, name, child in stack:
            out[name] -= child
    return out


def profile(args) -> int:
    import jax
    import numpy as np

    from jaxnav.core.config import load_config
    from jaxnav.run.training import Run

    cfg = load_config(
        "configs/paper_no_obstacles.yaml",
        [
            f"seeds={args.runs}",
            "strategies=[ebe]",
            f"env.n_beams={args.beams}",
            f"run.chunk_steps={args.steps}",
            *args.set,
        ],
    )
    run = Run(cfg, None, quiet=True)  # jaxnav train's own programs, no files
    shard, n = run.shard, np.int32(args.steps)
    ts = run.fresh_state()
    compiled = run.chunk.lower(ts, n).compile()
    sources = _op_sources(compiled.as_text())
    for _ in range(2):  # past learning_starts, warm
        ts, _ = compiled(ts, n)
    jax.block_until_ready(ts)
    walls = []
    with tempfile.TemporaryDirectory() as d:
        with jax.profiler.trace(d, create_perfetto_trace=True):
            for _ in range(args.reps):
                t0 = time.perf_counter()
                ts, _ = compiled(ts, n)
                jax.block_until_ready(ts)
                walls.append(time.perf_counter() - t0)
        (path,) = glob.glob(f"{d}/**/*.trace.json.gz", recursive=True)
        with gzip.open(path) as f:
            events = json.load(f)["traceEvents"]
    per_op = _self_times([e for e in events if e.get("ph") == "X" and e.get("name") in sources])
    total = sum(per_op.values())
    if not total:
        print("the trace has no XLA operation events (this jax does not record them on CPU)")
        return 1
    groups: collections.Counter = collections.Counter()
    for name, us in per_op.items():
        src = sources.get(name, "")
        group = next((g for g, rx in GROUPS if re.search(rx, src)), "other")
        groups[group] += us
    wall = statistics.median(walls)
    steps = args.steps * args.runs
    print(
        f"# {args.runs} runs, {args.beams} beams, {args.steps}-step chunks: "
        f"{steps / wall:,.0f} transitions/s; {1e6 * wall / args.steps:.0f} us per lockstep "
        f"step wall-clock, {total / args.reps / args.steps:.0f} us of XLA operations per step "
        f"summed over {shard.n_devices} device(s)"
    )
    cover = total / (sum(walls) * 1e6 * shard.n_devices)
    print(
        f"# the operations the trace names cover {100 * cover:.0f}% of the devices' wall-clock; "
        "the rest is XLA's CPU runtime around them (ThunkExecutor), which the trace does "
        "not split by operation"
    )
    print("\n| part of the step | share of operation time |\n|---|--:|")
    for g, us in groups.most_common():
        print(f"| {g} | {100 * us / total:.1f}% |")
    print("\n| top operations | share | source |\n|---|--:|---|")
    for name, us in per_op.most_common(args.top):
        src = re.sub(r"\s+", " ", sources.get(name, ""))[:110]
        print(f"| {name} | {100 * us / total:.1f}% | {src} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
