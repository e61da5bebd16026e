"""Every benchmark in one run, and one table: each peer's figure next to ours.

Runs, each script in its own process, ``--runs`` times (medians over the runs):

1. bench/train_throughput.py: our trainer alone, 1 and 32 seeds, 24 and 360 beams;
2. bench/env_throughput.py: environment steps/s, ours and JaxMARL's JaxNav;
3. bench/peers_sb3.py: Stable-Baselines3 DQN (PyTorch CPU) on jaxnav.interop.gym, the
   wrapper alone, and ours at 1 and 32 seeds;
4. bench/peers_rejax.py: rejax's DQN (JAX) on our environment and ours, 1 and 32 seeds;
5. bench/roofline.py: this CPU's float32 matmul peak, the learner's FLOPs and ours at
   32 seeds;

and then, once, bench/end_to_end.py: whole commands as a user waits for them
(compilation included) beside the steady state, and a second table of the speed
targets, each beside its measured figure.

Each ratio is taken from one script, whose two figures are measured back to back:
on a shared machine the load moves within minutes. The trainer settings (steps per
timed chunk, repetitions, replay capacity) are the same for ours and for every
learning peer.

    python bench/all.py                    # full: 3 runs (long; a quiet machine please)
    python bench/all.py --quick            # 1 run of every script's --quick
    python bench/all.py --quick --write-readme   # and put the table in bench/README.md

A peer that is not installed is reported as skipped (bench/README.md says how to
install them).
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

from common import BENCH, child_env, find_python, machine
from end_to_end import markdown as targets_markdown
from end_to_end import targets

README = BENCH / "README.md"
BEGIN, END = "<!-- bench/all.py table: begin -->", "<!-- bench/all.py table: end -->"


def run_script(python: str, script: str, args: list[str], log) -> dict | None:
    """Run ``script --json tmp args``; its JSON, or None (failure logged)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "r.json")
        cmd = [python, str(BENCH / script), *args, "--json", out]
        log(f"$ {' '.join([Path(python).name, 'bench/' + script, *args])}")
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=child_env())
        for line in p.stdout.strip().splitlines():
            log("    " + line)
        log(f"    ({time.perf_counter() - t0:.0f} s)")
        if p.returncode != 0 or not os.path.exists(out):
            tail = (p.stderr.strip().splitlines() or ["no output"])[-1]
            log(f"    failed: {tail}")
            return None
        with open(out) as f:
            return json.load(f)


def one_run(quick: bool, log) -> dict:
    """Figures of one run, keyed by row."""
    q = ["--quick"] if quick else []
    fig: dict[str, float] = {}

    r = run_script(
        sys.executable,
        "train_throughput.py",
        [*q, "--seeds", "1", "32", "--beams", "24", "360"],
        log,
    )
    for row in r or []:
        fig[f"ours:{row['seeds']}:{row['beams']}"] = row["transitions_per_s"]

    r = run_script(sys.executable, "env_throughput.py", q, log)
    if r:
        for row in r["jaxnav"]:
            fig[f"env:{row['beams']}:{row['envs']}"] = row["steps_per_s"]
        for k, v in r["peer"].items():
            if isinstance(v, dict):
                fig[f"env_peer:{k}"] = v["steps_per_s"]

    sb3_py = find_python("stable_baselines3")
    if sb3_py:
        r = run_script(sb3_py, "peers_sb3.py", [*q, "--seeds", "1", "32"], log)
        if r:
            fig["sb3"] = r["sb3"]["transitions_per_s"]
            if r.get("sb3_parallel"):
                fig["sb3_parallel"] = r["sb3_parallel"]["transitions_per_s"]
                fig["sb3_processes"] = r["sb3_parallel"]["processes"]
            fig["wrapper"] = r["wrapper"]["steps_per_s"]
            fig["sb3_env_share"] = r["env_share"]
            for seeds, v in r["ours"].items():
                fig[f"sb3_ours:{seeds}"] = v
    else:
        log("SB3 skipped: stable-baselines3 not installed (bench/README.md)")

    r = run_script(sys.executable, "peers_rejax.py", [*q, "--seeds", "1", "32"], log)
    for row in r or []:
        fig[f"rejax_ours:{row['seeds']}"] = row["ours"]
        if row.get("peer"):
            fig[f"rejax:{row['seeds']}"] = row["peer"]

    r = run_script(sys.executable, "roofline.py", q, log)
    if r:
        fig["peak"] = r["peak_gflops"]
        for row in r["rows"]:
            fig[f"flops:{row['beams']}"] = row["flops_per_transition"]
            fig[f"roof_ours:{row['beams']}"] = row["transitions_per_s"]
    return fig


def median_figures(runs: list[dict]) -> dict:
    keys = {k for r in runs for k in r}
    return {k: statistics.median([r[k] for r in runs if k in r]) for k in keys}


def fmt(x: float | None, unit: str = "") -> str:
    if x is None:
        return "—"
    return f"{x:,.0f}{unit}" if x >= 100 else f"{x:,.2f}{unit}" if x < 10 else f"{x:,.1f}{unit}"


def table(f: dict, quick: bool, runs: int, header: str) -> str:
    q = " --quick" if quick else ""
    rows = []  # (measure, peer, peer figure, ours, ratio, command)

    def ratio(ours, peer):
        return f"{ours / peer:.1f}x" if ours and peer else "—"

    env_keys = sorted(tuple(map(int, k.split(":")[1:])) for k in f if k.startswith("env:"))
    for beams, envs in env_keys:
        ours, peer = f.get(f"env:{beams}:{envs}"), f.get(f"env_peer:{beams}:{envs}")
        rows.append(
            (
                f"env steps/s, random actions, {beams} beams, {envs} env{'s' * (envs > 1)}",
                "JaxMARL JaxNav (jaxmarl 0.2)",
                fmt(peer),
                fmt(ours),
                ratio(ours, peer),
                f"python bench/env_throughput.py{q}",
            )
        )
    for seeds in (1, 32):
        ours = f.get(f"sb3_ours:{seeds}")
        sb3, peer_name = f.get("sb3"), "SB3 DQN, PyTorch CPU, 1 thread, one process"
        if seeds > 1 and f.get("sb3_parallel"):  # many seeds: one SB3 process per core
            n = int(f["sb3_processes"])
            sb3, peer_name = (
                f["sb3_parallel"],
                f"SB3 DQN, PyTorch CPU, {n} processes at once (1 per core)",
            )
        rows.append(
            (
                f"training transitions/s, {seeds} seed{'s' * (seeds > 1)}, 24 beams",
                peer_name,
                fmt(sb3),
                fmt(ours),
                ratio(ours, sb3),
                f"python bench/peers_sb3.py{q}",
            )
        )
    if "wrapper" in f:
        rows.append(
            (
                "jaxnav.interop.gym wrapper alone, steps/s (random actions)",
                f"= {100 * f['sb3_env_share']:.0f}% of SB3's time per transition",
                fmt(f["wrapper"]),
                "—",
                "—",
                f"python bench/peers_sb3.py{q}",
            )
        )
    for seeds in (1, 32):
        ours, peer = f.get(f"rejax_ours:{seeds}"), f.get(f"rejax:{seeds}")
        rows.append(
            (
                f"training transitions/s, {seeds} seed{'s' * (seeds > 1)}, 24 beams",
                "rejax 0.1.3 DQN (JAX)",
                fmt(peer),
                fmt(ours),
                ratio(ours, peer),
                f"python bench/peers_rejax.py{q}",
            )
        )
    for beams in (24, 360):
        for seeds in (1, 32):
            ours = f.get(f"ours:{seeds}:{beams}")
            rows.append(
                (
                    f"training transitions/s, {seeds} seed{'s' * (seeds > 1)}, {beams} beams "
                    "(ours alone)",
                    "—",
                    "—",
                    fmt(ours),
                    "—",
                    f"python bench/train_throughput.py{q}",
                )
            )
    peak = f.get("peak")
    for beams in (24, 360):
        ours, fl = f.get(f"roof_ours:{beams}"), f.get(f"flops:{beams}")
        achieved = ours * fl / 1e9 if ours and fl else None
        rows.append(
            (
                f"learner GFLOP/s vs float32 matmul peak, 32 seeds, {beams} beams "
                f"({fl / 1e6:.2f} MFLOP/transition)"
                if fl
                else f"learner GFLOP/s, 32 seeds, {beams} beams",
                "this CPU's jnp.dot peak",
                fmt(peak),
                fmt(achieved),
                f"{100 * achieved / peak:.1f}% of peak" if achieved and peak else "—",
                f"python bench/roofline.py{q}",
            )
        )
    lines = [
        header,
        "",
        "| measure | peer | peer | ours | ours / peer | command |",
        "|---|---|--:|--:|--:|---|",
    ]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def write_readme(text: str) -> None:
    old = README.read_text() if README.exists() else "# Benchmarks\n"
    block = f"{BEGIN}\n{text}\n{END}"
    if BEGIN in old and END in old:
        new = old[: old.index(BEGIN)] + block + old[old.index(END) + len(END) :]
    else:
        new = old.rstrip("\n") + "\n\n" + block + "\n"
    README.write_text(new)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="every script's --quick")
    ap.add_argument(
        "--runs", type=int, help="repetitions of everything (median); default 3, quick 1"
    )
    ap.add_argument("--json", help="also write the figures here")
    ap.add_argument("--write-readme", action="store_true", help=f"put the table into {README.name}")
    args = ap.parse_args(argv)
    runs = args.runs or (1 if args.quick else 3)
    log = lambda s: print(s, flush=True)  # noqa: E731

    m0, t0 = machine(), time.time()
    figs = []
    for i in range(runs):
        log(f"== run {i + 1} of {runs}")
        figs.append(one_run(args.quick, log))
    f = median_figures(figs)
    log("== whole commands")
    e2e = run_script(sys.executable, "end_to_end.py", ["--quick"] if args.quick else [], log)
    load1 = os.getloadavg()[0]
    header = (
        f"`python bench/all.py{' --quick' if args.quick else ''}`, "
        f"{time.strftime('%Y-%m-%d', time.gmtime(t0))}, median of {runs} run{'s' * (runs > 1)}, "
        f"{(time.time() - t0) / 60:.0f} min; machine: {m0} (load before), load after {load1:.1f}."
    )
    text = table(f, args.quick, runs, header)
    q = " --quick" if args.quick else ""
    text += f"\n\nThe speed targets, from `python bench/end_to_end.py{q}` in the same run:\n\n" + (
        targets_markdown(targets(e2e)) if e2e else "bench/end_to_end.py failed (log above)"
    )
    print()
    print(text)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"runs": figs, "median": f, "end_to_end": e2e}, fh, indent=1)
    if args.write_readme:
        write_readme(text)
        print(f"\n(written to {README})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
