"""The pretrained policies that ship with jaxnav (``jaxnav/policies/NAME.npz``, each
beside ``NAME.md``: the config and the test table that made it), found by name.

The standard library only, as :mod:`jaxnav.robot.deploy`: a robot's node (ROS 1 or 2)
takes ``--policy NAME|FILE`` from its command line with :func:`policy_arg` and finds the
file with :func:`node_policy_file`: a file by its path, a policy beside the node, or a
shipped one by name. Copied beside a node on a robot without jaxnav, it still reads
``--policy`` and finds files by path or beside the node.
"""

from __future__ import annotations

import difflib
import os
from pathlib import Path

try:  # inside the jaxnav package: its one error type
    from jaxnav.core.errors import PolicyError
except ImportError:  # beside a robot's node, without jaxnav
    PolicyError = ValueError  # type: ignore[misc, assignment]

POLICY_DIR = Path(__file__).resolve().parent.parent / "policies"


def shipped_policies() -> dict[str, Path]:
    """Each shipped policy's name and its file, in name order."""
    if not POLICY_DIR.is_dir():
        return {}
    return {p.stem: p for p in sorted(POLICY_DIR.glob("*.npz"))}


def policy_path(name_or_file: str | os.PathLike) -> Path:
    """A policy file: ``name_or_file`` itself where it is a file, else the shipped
    policy of that name; PolicyError (one line, naming the shipped ones) otherwise."""
    path = Path(name_or_file)
    if path.is_file():
        return path
    shipped = shipped_policies()
    if str(name_or_file) in shipped:
        return shipped[str(name_or_file)]
    near = difflib.get_close_matches(str(name_or_file), list(shipped), n=1, cutoff=0.6)
    hint = f" (did you mean {near[0]!r}?)" if near else ""
    names = ", ".join(shipped) or "none"
    raise PolicyError(
        f"no policy file {name_or_file} and no shipped policy of that name{hint}; shipped: {names}"
    )


def policy_arg(argv: list[str]) -> str | None:
    """``--policy NAME|FILE`` from a node's command line (taken out of ``argv``, so that
    ROS reads the rest), or None."""
    if "--policy" not in argv:
        return None
    i = argv.index("--policy")
    value = argv[i + 1] if i + 1 < len(argv) else None
    del argv[i : i + 2]
    return value


def node_policy_file(name_or_file: str, beside: str | os.PathLike) -> str:
    """The policy file a node at ``beside`` (its folder) drives with: a file by its path,
    else ``NAME.npz`` in that folder, else the shipped policy of that name (PolicyError
    where there is none); on a robot without jaxnav's policies, the name as given (the
    node's load then says it cannot read it)."""
    if Path(name_or_file).is_file():
        return str(name_or_file)
    near = Path(beside) / f"{name_or_file}.npz"
    if near.is_file():
        return str(near)
    if not shipped_policies():
        return str(name_or_file)
    return str(policy_path(name_or_file))


__all__ = ["POLICY_DIR", "node_policy_file", "policy_arg", "policy_path", "shipped_policies"]
