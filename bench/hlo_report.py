"""What one training step executes, read from the compiled program (no timing).

Lowers and compiles the chunk of ``jaxnav train`` exactly as the command does (its
``Run``, vmapped over the runs, the run axis laid over the CPU devices), from shapes
alone (no buffer is allocated), and reads the per-device program XLA emits
(``compile().as_text()``). The step is the body of the chunk's loop; every
instruction there runs once per environment step. Printed:

* the step's kernels: the instructions that do work (fusions, dots, copies, nested
  loops, conditionals), per part of the step (the named scopes of ``jaxnav.dqn``);
* every ``copy`` in the step, by shape, with the bytes it moves per step;
* every update of a carried array (scatter, dynamic-update-slice) with the array it
  writes and whether a copy of that array exists in the step (an update that is not
  in place);
* the selects that write a carried array (the parameter tree, the optimiser state,
  the metrics rings, the buffer), by part and shape, with their bytes;
* the gathers, with the array each reads from (the replay sample's rows);
* conditionals and cross-device collectives in the step.

    python bench/hlo_report.py                       # paper config, 64 runs, 2 devices
    python bench/hlo_report.py smoke seeds=32 --dump /tmp/chunk.hlo
"""

from __future__ import annotations

import argparse
import collections
import math
import os
import re
import sys

DTYPE_BYTES = {"f32": 4, "s32": 4, "u32": 4, "u8": 1, "s8": 1, "pred": 1, "f64": 8, "s64": 8}
FREE = {"parameter", "get-tuple-element", "tuple", "constant", "bitcast"}
PARTS = ("keys", "act", "env_step", "replay_add", "replay_sample", "learn")
HEADER = re.compile(r"^(?:ENTRY )?%(\S+) \(.*\{$")


def _matching(text: str) -> int:
    """Index of the parenthesis that closes ``text``'s first one."""
    depth = 0
    for i, c in enumerate(text):
        depth += (c == "(") - (c == ")")
        if depth == 0:
            return i
    return len(text) - 1


class Op:
    """One instruction of the HLO text."""

    def __init__(self, line: str):
        s = line[5:] if line.startswith("ROOT ") else line
        name, rest = s.split(" = ", 1)
        if rest.startswith("("):  # a tuple type: up to its matching parenthesis
            end = _matching(rest)
            self.type, rest = rest[: end + 1], rest[end + 2 :]
        else:
            self.type, rest = rest.split(" ", 1)
        self.name = name.lstrip("%")
        self.opcode = rest.split("(", 1)[0]
        args = rest.split("(", 1)[1] if "(" in rest else ""
        self.operands = re.findall(r"%([\w.\-]+)", args.split("), ")[0])
        meta = re.search(r'op_name="([^"]*)"', line)
        self.op_name = meta.group(1) if meta else ""
        self.calls = [
            c.strip().lstrip("%")
            for group in re.findall(r"(?:calls|body|condition|to_apply)=(%[\w.\-]+)", line)
            for c in group.split(",")
        ]
        self.kind = (re.search(r"kind=(\w+)", line) or [None, ""])[1]

    @property
    def elements(self) -> int:
        m = re.match(r"\w+\[([\d,]*)\]", self.type)
        return math.prod(int(d) for d in m.group(1).split(",") if d) if m else 0

    @property
    def nbytes(self) -> int:
        dtype = self.type.split("[", 1)[0]
        return self.elements * DTYPE_BYTES.get(dtype, 4)

    @property
    def shape(self) -> str:
        return re.sub(r"\{[^}]*\}", "", self.type)

    @property
    def part(self) -> str:
        """The step's part (named scope) the instruction comes from."""
        found = [p for p in PARTS if f"/{p}/" in self.op_name + "/"]
        if "replay_sample" in found:
            return "replay_sample"
        if "learn" in found or "/learn" in self.op_name:
            gradient = "jvp(" in self.op_name or "transpose(" in self.op_name
            return "learn: gradient" if gradient else "learn: optimiser and guard"
        if found:
            return found[0]
        return "unscoped (target sync, episode records, held state, logs)"


def _bytes(shape: str) -> int:
    m = re.match(r"(\w+)\[([\d,]*)\]", shape)
    n = math.prod(int(d) for d in m.group(2).split(",") if d)
    return n * DTYPE_BYTES.get(m.group(1), 4)


def parse(text: str) -> dict[str, list[Op]]:
    """Computations of an HLO module: name -> instructions."""
    comps: dict[str, list[Op]] = {}
    cur = None
    for line in text.splitlines():
        m = HEADER.match(line)
        if m:
            cur = comps.setdefault(m.group(1), [])
        elif line == "}":
            cur = None
        elif cur is not None and line.strip().startswith(("%", "ROOT")):
            cur.append(Op(line.strip()))
    return comps


def step_body(comps: dict[str, list[Op]]) -> list[Op]:
    """The instructions of the chunk loop's body: the outermost while of the entry."""
    entry = list(comps)[-1]
    loops = [op for op in comps[entry] if op.opcode == "while"]
    loop = max(loops, key=lambda op: op.type.count(","))  # the one carrying the state
    return comps[[c for c in loop.calls if "region_0" in c or "body" in c][-1]]


def inner_ops(comps, op: Op) -> collections.Counter:
    """Opcodes inside a fusion (and what it calls)."""
    out: collections.Counter = collections.Counter()
    for c in op.calls:
        for inner in comps.get(c, []):
            out[inner.opcode] += 1
    return out


def compiled_text(config: str, overrides: list[str], devices: int) -> str:
    """The per-device HLO of jaxnav train's chunk, compiled from shapes."""
    flag = f"--xla_force_host_platform_device_count={devices}"
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {flag}".strip()
    import jax
    import numpy as np

    from jaxnav.agent.trainer import run_inputs
    from jaxnav.core.config import load_config
    from jaxnav.run.training import Run

    cfg = load_config(config, overrides)
    run = Run(cfg, None, quiet=True)
    shapes = jax.eval_shape(jax.vmap(run.trainer.init), *run_inputs(cfg))
    shapes = jax.tree.map(
        lambda s: jax.ShapeDtypeStruct(
            (run.shard.padded, *s.shape[1:]), s.dtype, sharding=run.shard.sharding
        ),
        shapes,
    )
    return run.chunk.lower(shapes, np.int32(0)).compile().as_text()


def report(text: str, big: int) -> None:
    comps = parse(text)
    body = step_body(comps)
    types = {op.name: op for op in body}
    work = [op for op in body if op.opcode not in FREE]
    print(f"kernels per step: {len(work)}")
    per_part = collections.Counter(op.part for op in work)
    for part, n in per_part.most_common():
        print(f"  {part}: {n}")
    opcodes = collections.Counter(op.opcode for op in work)
    print("  by opcode: " + ", ".join(f"{k} {v}" for k, v in opcodes.most_common()))

    copies = [op for op in body if op.opcode == "copy"]
    by_shape = collections.Counter(op.shape for op in copies)
    nbytes = sum(op.nbytes for op in copies)
    print(f"copies per step: {len(copies)}, {nbytes:,} bytes")
    for shape, n in by_shape.most_common():
        print(f"  {n} x {shape}")
    whole = collections.Counter(op.opcode for c in comps.values() for op in c)
    print(f"copies in the whole module: {whole['copy']}")

    copied = {op.shape for op in copies}
    updates = [
        op
        for op in body
        if op.opcode == "fusion"
        and ({"scatter", "dynamic-update-slice"} & set(inner_ops(comps, op)))
    ]
    print(f"updates of carried arrays per step: {len(updates)}")
    for op in updates:
        how = "scatter" if "scatter" in inner_ops(comps, op) else "dynamic-update-slice"
        place = "a copy of it exists" if op.shape in copied else "in place"
        print(f"  {how} into {op.shape} ({op.part}): {place}")

    carried = set(re.findall(r"\w+\[[\d,]*\]", body[0].type)) if body else set()
    selects = [
        op
        for op in work
        if op.shape in carried
        and op.part != "learn: gradient"
        and (op.opcode == "select" or (op.opcode == "fusion" and "select" in inner_ops(comps, op)))
        and not {"scatter", "dynamic-update-slice", "dot", "gather"} & set(inner_ops(comps, op))
    ]
    sel_bytes = sum(op.nbytes for op in selects)
    print(f"selects writing a carried array per step: {len(selects)}, {sel_bytes:,} bytes")
    groups = collections.Counter((op.part, op.shape) for op in selects)
    for (part, shape), n in sorted(groups.items(), key=lambda kv: -kv[1] * _bytes(kv[0][1])):
        if n * _bytes(shape) >= big:
            print(f"  {n} x {shape} ({part})")
    small = sum(n for (_, shape), n in groups.items() if n * _bytes(shape) < big)
    print(f"  and {small} smaller ones (under {big} bytes each group)")

    gathers = [op for op in work if op.opcode == "fusion" and "gather" in inner_ops(comps, op)]
    print(f"fusions with a gather per step: {len(gathers)}")
    for op in gathers:
        sources = sorted(
            {types[o].shape for o in op.operands if o in types and types[o].nbytes >= big},
            key=len,
        )
        if sources:
            print(f"  {op.shape} from {', '.join(sources)} ({op.part})")

    cond = sum(op.opcode == "conditional" for op in body)
    coll = sum(
        op.opcode.startswith(("all-reduce", "all-gather", "collective", "all-to-all"))
        for c in comps.values()
        for op in c
    )
    print(f"conditionals per step: {cond}; collectives in the module: {coll}")


def main() -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("config", nargs="?", default="configs/paper_no_obstacles.yaml")
    p.add_argument("overrides", nargs="*", help="key=value (default seeds=32)")
    p.add_argument(
        "--devices", type=int, default=2, help="CPU devices (jaxnav train: one per core)"
    )
    p.add_argument("--big", type=int, default=4096, help="bytes below which selects are summed")
    p.add_argument("--dump", help="also write the compiled program's text here")
    args = p.parse_args()
    overrides = args.overrides or ["seeds=32"]
    text = compiled_text(args.config, overrides, args.devices)
    if args.dump:
        with open(args.dump, "w") as f:
            f.write(text)
    print(f"# {args.config} {' '.join(overrides)}, {args.devices} devices, per-device program")
    report(text, args.big)
    return 0


if __name__ == "__main__":
    sys.exit(main())
