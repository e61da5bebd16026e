"""``python -m jaxnav.plots``: figures of a run, from its files.

The work is :mod:`jaxnav.report.plots`; ``--help`` lists the options.
"""

import sys

from jaxnav.report.plots import main

if __name__ == "__main__":
    sys.exit(main())
