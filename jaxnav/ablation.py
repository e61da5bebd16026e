"""``python -m jaxnav.ablation``: both experiments under each ROBOTIS-faithful switch.

Its report is ``ablation.md``.

The work is :mod:`jaxnav.experiments.ablation`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

from jaxnav.experiments.ablation import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
