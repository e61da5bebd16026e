"""``python -m jaxnav.reproduce``: the paper's two experiments end to end, and ``report.md``.

The work is :mod:`jaxnav.experiments.reproduce`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

from jaxnav.experiments.reproduce import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
