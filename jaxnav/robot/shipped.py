"""The pretrained policies that ship with jaxnav (``jaxnav/policies/NAME.npz``, each
beside ``NAME.md``: the config and the test table that made it), found by name.

NumPy and the standard library only, as :mod:`jaxnav.robot.deploy`: a robot's node
finds a shipped policy by name (``--policy drive_anywhere``) with this module, or a
policy file by its path.
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


__all__ = ["POLICY_DIR", "policy_path", "shipped_policies"]
