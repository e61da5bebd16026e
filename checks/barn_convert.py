"""Re-derive jaxnav's BARN data from The BARN Challenge's own repository, byte for byte.

jaxnav ships BARN's 300 worlds as ``jaxnav/configs/barn/barn.npz``, converted by
``jaxnav.world.barn_convert`` from ``Daffan/the-barn-challenge``'s world and path files.
This script reads those files from a copy of that repository (a clone, or a bare git
directory such as ``fetch`` leaves), converts them again and compares the result with the
shipped file, byte for byte. It names the commit it read. CI cannot reach the
repository, so it is run by hand:

    git clone https://github.com/Daffan/the-barn-challenge /tmp/barn
    python checks/barn_convert.py /tmp/barn            # a clone's work tree
    python checks/barn_convert.py --git-dir REPO.git   # a bare git directory (HEAD)

Exit status 0: identical; 1: different (the first difference said); 2: bad input.
"""

from __future__ import annotations

import argparse
import hashlib
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jaxnav.world import barn_convert  # noqa: E402
from jaxnav.world.barn import DATA  # noqa: E402


def reader(tree: Path | None, git_dir: str | None):
    """(read(path) -> bytes, the commit read)."""
    if git_dir is not None:
        commit = subprocess.run(
            ["git", "--git-dir", git_dir, "rev-parse", "HEAD"],
            capture_output=True, text=True, check=True,
        ).stdout.strip()  # fmt: skip

        def read(path: str) -> bytes:
            return subprocess.run(
                ["git", "--git-dir", git_dir, "show", f"{commit}:{path}"],
                capture_output=True, check=True,
            ).stdout  # fmt: skip

        return read, commit
    run = subprocess.run(
        ["git", "-C", str(tree), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    commit = run.stdout.strip() if run.returncode == 0 else "(not a git work tree)"
    return (lambda path: (tree / path).read_bytes()), commit


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("tree", nargs="?", help="a clone of Daffan/the-barn-challenge")
    p.add_argument("--git-dir", help="a git directory of it instead (its HEAD is read)")
    args = p.parse_args(argv)
    if (args.tree is None) == (args.git_dir is None):
        print(
            "barn_convert: give the repository's work tree or --git-dir, one of them",
            file=sys.stderr,
        )
        return 2
    try:
        read, commit = reader(Path(args.tree) if args.tree else None, args.git_dir)
        data = barn_convert.convert(read)
    except (OSError, subprocess.CalledProcessError, barn_convert.BarnFormatError) as e:
        print(f"barn_convert: cannot convert: {e}", file=sys.stderr)
        return 2
    shipped = DATA.read_bytes()
    print(f"read Daffan/the-barn-challenge at commit {commit}")
    print(f"converted: {len(data)} bytes, sha256 {hashlib.sha256(data).hexdigest()}")
    print(f"shipped:   {len(shipped)} bytes, sha256 {hashlib.sha256(shipped).hexdigest()}")
    if data == shipped:
        print("identical: jaxnav/configs/barn/barn.npz is the conversion of these files")
        return 0
    first = next(
        (i for i, (a, b) in enumerate(zip(data, shipped)) if a != b), min(len(data), len(shipped))
    )
    print(f"DIFFERENT from byte {first}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
