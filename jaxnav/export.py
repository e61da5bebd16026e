"""``python -m jaxnav.export``: one trained policy to a portable file.

The work is :mod:`jaxnav.robot.export`; ``--help`` lists the options.
"""

import sys

if __name__ == "__main__":  # first thing: Ctrl-C ends the command cleanly
    from jaxnav.core.startup import catch_interrupts_in_command

    catch_interrupts_in_command()

from jaxnav.robot.export import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
