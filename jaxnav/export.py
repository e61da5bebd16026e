"""``python -m jaxnav.export``: one trained policy to a portable file.

The work is :mod:`jaxnav.robot.export`; ``--help`` lists the options.
"""

import sys

from jaxnav.robot.export import main

if __name__ == "__main__":
    sys.exit(main())
