"""Environment throughput: random-policy steps per second of whole rollouts under jit.

Each measurement is one ``jax.jit``-compiled function that resets N vmapped
environments and runs a ``lax.scan`` of S steps with uniformly random actions
(auto-reset included, observations consumed so nothing is optimised away). The
time excludes compilation; it is the median of several repetitions with fresh
keys. Every configuration runs in its own process, so the peak memory (ru_maxrss)
belongs to it alone.

The optional peer is JaxMARL's JaxNav (PyPI ``jaxmarl``), the closest existing
JAX LiDAR navigation environment, run single-agent with discrete actions, the same
beam count and the same 3.5 m range, through the same harness. It runs with the
interpreter of ``.venv-peers`` (see bench/README.md) or this one if it has jaxmarl;
without it the peer is skipped.

    python bench/env_throughput.py                    # full table (~10 min on 2 cores)
    python bench/env_throughput.py --quick            # smoke run
    python bench/env_throughput.py --profile          # where a step's time goes
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PEER_VENV_PYTHON = ROOT / ".venv-peers" / "bin" / "python"
MARK = "RESULT "


# ----------------------------------------------------------------------------
# Harness (shared by jaxnav and the peer; imports only jax)
# ----------------------------------------------------------------------------


def measure(run, reps: int) -> dict:
    """Compile ``run(key)`` once, then time ``reps`` calls; returns seconds."""
    import jax

    t0 = time.perf_counter()
    compiled = jax.jit(run).lower(jax.random.PRNGKey(0)).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(jax.random.PRNGKey(1)))  # warm-up (allocations)
    times = []
    for i in range(reps):
        t = time.perf_counter()
        jax.block_until_ready(compiled(jax.random.PRNGKey(2 + i)))
        times.append(time.perf_counter() - t)
    return {"compile_s": compile_s, "times_s": times, "median_s": statistics.median(times)}


def env_sharding(n_envs: int):
    """The batch of environments laid over every device (None: one device, or a batch
    the device count does not divide)."""
    import jax
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    devices = jax.devices()
    if len(devices) < 2 or n_envs % len(devices):
        return None
    return NamedSharding(Mesh(devices, ("envs",)), PartitionSpec("envs"))


def rollout(reset, step, n_actions: int, n_envs: int, n_steps: int):
    """A random-policy rollout of n_envs environments for n_steps, as ``run(key)``.

    ``reset(keys) -> (obs, state)`` and ``step(keys, state, actions) -> (obs, state,
    reward, done)`` are already vmapped; obs is an array. Returns a scalar checksum of
    every observation, reward and done so that the compiler keeps all the work.
    With several devices the environments are split evenly over them (the compiler
    partitions the whole rollout; each device steps its own environments)."""
    import jax
    import jax.numpy as jnp

    sharding = env_sharding(n_envs)

    def spread(tree):
        if sharding is None:
            return tree
        return jax.tree.map(lambda x: jax.lax.with_sharding_constraint(x, sharding), tree)

    def run(key):
        k_reset, k_run = jax.random.split(key)
        obs, state = reset(spread(jax.random.split(k_reset, n_envs)))
        state = spread(state)

        def body(carry, _):
            state, key, acc = carry
            key, k_act, k_step = jax.random.split(key, 3)
            actions = spread(jax.random.randint(k_act, (n_envs,), 0, n_actions))
            obs, state, reward, done = step(
                spread(jax.random.split(k_step, n_envs)), state, actions
            )
            state = spread(state)
            # Per environment, so that devices never wait on each other mid-rollout.
            acc = acc + obs.reshape(n_envs, -1).sum(-1) + reward + done
            return (state, key, acc), None

        acc0 = spread(obs.reshape(n_envs, -1).sum(-1))
        (_, _, acc), _ = jax.lax.scan(body, (state, k_run, acc0), None, length=n_steps)
        return jnp.sum(acc)

    return run


def jaxnav_fns(n_beams: int, maze: str):
    import jax

    import jaxnav

    env, params = jaxnav.make(maze, n_beams=n_beams)

    def reset(keys):
        return jax.vmap(env.reset, in_axes=(0, None))(keys, params)

    def step(keys, state, actions):
        obs, state, reward, term, trunc, _ = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
            keys, state, actions, params
        )
        return obs, state, reward, term | trunc

    return reset, step, env.num_actions, f"jaxnav {maze}"


def jaxmarl_fns(n_beams: int, maze: str):
    import contextlib
    import io
    import warnings

    import jax

    warnings.filterwarnings("ignore", category=FutureWarning)
    with contextlib.redirect_stdout(io.StringIO()):  # it prints on import
        from jaxmarl.environments.jaxnav import JaxNav

    env = JaxNav(num_agents=1, act_type="Discrete", lidar_num_beams=n_beams, lidar_max_range=3.5)
    agent = env.agents[0]

    def reset(keys):
        obs, state = jax.vmap(env.reset)(keys)
        return obs[agent], state

    def step(keys, state, actions):
        obs, state, reward, dones, _ = jax.vmap(env.step)(keys, state, {agent: actions})
        return obs[agent], state, reward[agent], dones["__all__"]

    return reset, step, env.action_space(agent).n, "JaxMARL JaxNav (Grid-Rand-Poly 11x11)"


def run_one(spec: str) -> dict:
    """Run one configuration 'KIND:BEAMS:ENVS:STEPS:REPS:MAZE' in this process."""
    import contextlib
    import io

    import jax

    kind, beams, envs, steps, reps, maze = spec.split(":")
    beams, envs, steps, reps = int(beams), int(envs), int(steps), int(reps)
    fns = {"jaxnav": jaxnav_fns, "jaxmarl": jaxmarl_fns}[kind]
    reset, step, n_actions, label = fns(beams, maze)
    with contextlib.redirect_stdout(io.StringIO()):  # jaxmarl prints while tracing
        res = measure(rollout(reset, step, n_actions, envs, steps), reps)
    dev = jax.devices()[0]
    res.update(
        n_devices=len(jax.devices()) if env_sharding(envs) is not None else 1,
        kind=kind,
        label=label,
        beams=beams,
        envs=envs,
        steps=steps,
        steps_per_s=envs * steps / res["median_s"],
        maxrss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        device=dev.platform
        if dev.platform == getattr(dev, "device_kind", "")
        else f"{dev.platform} {getattr(dev, 'device_kind', '')}".strip(),
        jax=jax.__version__,
    )
    return res


# ----------------------------------------------------------------------------
# Orchestration
# ----------------------------------------------------------------------------


def subprocess_run(python: str, spec: str, timeout: float, devices: int = 1) -> dict:
    from common import device_env  # CPU devices; each batch of environments is split over them

    env = device_env(devices)
    proc = subprocess.run(
        [python, str(Path(__file__).resolve()), "--one", spec],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
    )
    for line in proc.stdout.splitlines():
        if line.startswith(MARK):
            return json.loads(line[len(MARK) :])
    tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
    raise RuntimeError(f"{spec} failed: {tail}")


def find_peer_python(arg: str | None) -> tuple[str | None, str]:
    """The interpreter that has jaxmarl, or None and why not."""
    candidates = [arg] if arg else [sys.executable, str(PEER_VENV_PYTHON)]
    for py in candidates:
        if not py or not Path(py).exists():
            continue
        ok = subprocess.run(
            [
                py,
                "-c",
                "import importlib.util, sys; sys.exit(importlib.util.find_spec('jaxmarl') is None)",
            ],
            capture_output=True,
        )
        if ok.returncode == 0:
            return py, ""
    return None, (
        "jaxmarl not installed (python -m venv .venv-peers && "
        ".venv-peers/bin/pip install 'jax>=0.10,<0.11' jaxmarl; see bench/README.md)"
    )


def choose_steps(max_steps: int, envs: int, rate_hint: float | None, budget_s: float) -> int:
    """Steps per rollout: max_steps, fewer where a rollout would take over budget_s."""
    if rate_hint is None:
        return max_steps
    fit = int(budget_s * rate_hint / envs)
    for s in (max_steps, 500, 200, 100, 50, 20, 10):
        if s <= max_steps and s <= fit:
            return s
    return 10


def table(rows: list[dict], peer: dict, args) -> str:
    head = (
        f"{'beams':>5} {'envs':>5} {'dev':>3} {'steps':>5} | {'compile s':>9} {'rollout s':>9} "
        f"{'steps/s':>11} {'peak MB':>8}"
    )
    if peer:
        head += f" | {'steps':>5} {'JaxMARL steps/s':>15} {'peak MB':>8} {'ours/theirs':>11}"
    lines = [head, "-" * len(head)]
    for r in rows:
        line = (
            f"{r['beams']:>5} {r['envs']:>5} {r.get('n_devices', 1):>3} {r['steps']:>5} | "
            f"{r['compile_s']:>9.2f} "
            f"{r['median_s']:>9.3f} {r['steps_per_s']:>11,.0f} {r['maxrss_mb']:>8.0f}"
        )
        p = peer.get((r["beams"], r["envs"]))
        if isinstance(p, dict):
            line += (
                f" | {p['steps']:>5} {p['steps_per_s']:>15,.0f} {p['maxrss_mb']:>8.0f} "
                f"{r['steps_per_s'] / p['steps_per_s']:>10.1f}x"
            )
        elif peer:
            line += f" | {str(p or 'skipped'):>15}"
        lines.append(line)
    return "\n".join(lines)


def main(argv=None) -> int:
    from common import cores

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--maze", default="square4_obstacles")
    ap.add_argument("--envs", default="1,64,4096", help="comma-separated env counts")
    ap.add_argument("--beams", default="24,360", help="comma-separated beam counts")
    ap.add_argument("--steps", type=int, default=1000, help="steps per rollout (max)")
    ap.add_argument("--reps", type=int, default=5, help="timed repetitions (median)")
    ap.add_argument(
        "--budget",
        type=float,
        default=8.0,
        help="seconds one rollout may take; bigger configs get fewer steps",
    )
    ap.add_argument(
        "--devices",
        type=int,
        default=cores(),
        help="CPU devices to split the environments over, for both us and the peer "
        "(default: one per core, as jaxnav's commands use)",
    )
    ap.add_argument("--no-peer", action="store_true", help="skip JaxMARL's JaxNav")
    ap.add_argument(
        "--peer-python", help="interpreter with jaxmarl (default: this one or .venv-peers)"
    )
    ap.add_argument(
        "--quick", action="store_true", help="smoke run: 1, 64 and 4096 envs, 100 steps, 3 reps"
    )
    ap.add_argument("--profile", action="store_true", help="time the parts of one step instead")
    ap.add_argument("--json", help="also write the results to this file")
    args = ap.parse_args(argv)

    if args.one:
        print(MARK + json.dumps(run_one(args.one)), flush=True)
        return 0
    if args.profile:
        return profile(args)
    if args.quick:
        args.envs, args.steps, args.reps = "1,64,4096", 100, 3
    envs = [int(x) for x in args.envs.split(",")]
    beams = [int(x) for x in args.beams.split(",")]

    peer_py = None
    if not args.no_peer:
        peer_py, why = find_peer_python(args.peer_python)
        if not peer_py:
            print(f"peer skipped: {why}", flush=True)

    load0 = os.getloadavg()[0]
    rows, peer = [], {}
    for b in beams:
        hint = {"jaxnav": None, "jaxmarl": None}
        for n in envs:
            # Each env gets its own rollout length (steps/s is per step either way).
            steps = choose_steps(args.steps, n, hint["jaxnav"], args.budget)
            spec = f"jaxnav:{b}:{n}:{steps}:{args.reps}:{args.maze}"
            r = subprocess_run(sys.executable, spec, timeout=1800, devices=args.devices)
            rows.append(r)
            hint["jaxnav"] = r["steps_per_s"]
            msg = (
                f"jaxnav  {b:>3} beams {n:>5} envs x {steps:>4} steps: "
                f"{r['steps_per_s']:>11,.0f} steps/s"
            )
            if peer_py:
                p_steps = choose_steps(args.steps, n, hint["jaxmarl"], args.budget)
                p_spec = f"jaxmarl:{b}:{n}:{p_steps}:{args.reps}:{args.maze}"
                try:
                    p = subprocess_run(peer_py, p_spec, timeout=1800, devices=args.devices)
                    peer[(b, n)] = p
                    hint["jaxmarl"] = p["steps_per_s"]
                    msg += f" | JaxMARL x {p_steps:>4} steps: {p['steps_per_s']:>11,.0f} steps/s"
                except (RuntimeError, subprocess.TimeoutExpired) as e:
                    peer[(b, n)] = "failed"
                    msg += f" | JaxMARL failed: {e}"
            print(msg, flush=True)

    r0 = rows[0]
    print()
    print(
        f"Random-policy steps/s, {args.maze}, lax.scan rollouts under jit, median of "
        f"{args.reps}, compile excluded; {r0['device']}, {os.cpu_count()} CPU cores, "
        f"batches of environments split over {args.devices} device(s) where they divide, "
        f"jax {r0['jax']}, Python {platform.python_version()}; load average "
        f"{load0:.1f} before, {os.getloadavg()[0]:.1f} after"
    )
    print(table(rows, peer, args))
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {"jaxnav": rows, "peer": {f"{b}:{n}": v for (b, n), v in peer.items()}}, indent=1
            )
        )
    return 0


# ----------------------------------------------------------------------------
# Where a step's time goes
# ----------------------------------------------------------------------------


def profile(args) -> int:
    """Time the parts of env.step, each vmapped over the same batch and jitted."""
    import jax
    import jax.numpy as jnp

    import jaxnav

    n = int(args.envs.split(",")[-1])
    print(f"one step of {n} vmapped environments on {args.maze}, ms (median of {args.reps})")
    for b in [int(x) for x in args.beams.split(",")]:
        env, params = jaxnav.make(args.maze, n_beams=b)
        keys = jax.random.split(jax.random.PRNGKey(0), n)
        _, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
        # Spread the robots over the maze so the numbers are not all-equal shortcuts.
        pts = params.maze.goal_points[jnp.arange(n) % params.maze.n_goal_points]
        state = state.replace(pos=pts, yaw=jnp.linspace(-3, 3, n))
        actions = jnp.arange(n) % env.num_actions
        parts = _step_parts(env, params, b)
        print(f"-- {b} beams")
        for name, f in parts.items():
            g = jax.jit(jax.vmap(f))
            jax.block_until_ready(g(keys, state, actions))
            times = []
            for _ in range(args.reps):
                t = time.perf_counter()
                jax.block_until_ready(g(keys, state, actions))
                times.append(time.perf_counter() - t)
            ms = 1e3 * statistics.median(times)
            print(f"   {name:36s} {ms:9.2f} ms  ({1e6 * ms / 1e3 / n:7.2f} us per env)")
    return 0


def _step_parts(env, params, b: int) -> dict:
    """The parts of one environment step, each a function of (key, state, action)."""
    import jax
    import jax.numpy as jnp

    from jaxnav.world.geometry import path_clearance, ray_distances

    angles = jnp.arange(b, dtype=jnp.float32) * (2 * jnp.pi / b)
    return {
        "step (auto-reset, 2 scans)": lambda k, s, a: env.step(k, s, a, params),
        "step_env (no reset)": lambda k, s, a: env.step_env(k, s, a, params),
        "observe (scan, noise, heading)": lambda k, s, a: env.observe(
            k, s.pos, s.yaw, s.goal, params
        ),
        f"  LiDAR ray casting ({b} beams)": lambda k, s, a: ray_distances(
            params.maze, s.pos, s.yaw + angles
        ),
        f"  range noise draw ({b} normals)": lambda k, s, a: jax.random.normal(k, (b,)),
        "swept collision (path_clearance)": lambda k, s, a: path_clearance(
            params.maze, s.pos, s.yaw, params.omegas[a], params.v, params.dt
        ),
        "goal draw": lambda k, s, a: env.draw_goal(k, s.goal, params),
    }


if __name__ == "__main__":
    sys.exit(main())
