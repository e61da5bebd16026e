"""``python -m jaxnav.sim2sim``: a run's exported policies driving a TurtleBot3 burger in MuJoCo.

The work is :mod:`jaxnav.experiments.sim2sim`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    from jaxnav.core.startup import before_jax

    before_jax()

from jaxnav.experiments.sim2sim import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
