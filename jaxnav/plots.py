"""``python -m jaxnav.plots``: figures of a run, from its files.

The work is :mod:`jaxnav.report.plots`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

from jaxnav.report.plots import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
