"""``python -m jaxnav.train CONFIG [key=value ...] [--out RUN_DIR] [--resume RUN_DIR]``:
the main command's own form, the same as ``jaxnav train`` (:mod:`jaxnav.commands.train`)."""

from __future__ import annotations

if __name__ == "__main__":  # before JAX starts: one CPU device per core, compile cache
    import sys

    from jaxnav.core.startup import before_jax, catch_interrupts_in_command

    catch_interrupts_in_command()
    before_jax()
    from jaxnav.commands.train import main

    sys.exit(main())
