"""``python -m jaxnav.study``: a config's sweep trained, tested in both modes and written up.

The work is :mod:`jaxnav.experiments.study`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

from jaxnav.experiments.study import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
