"""Settings and plumbing, no JAX: config, settings, sweep axes, the strategy and maze-family
registries, errors, the command-line helpers, start-up and the run directory on disk.

Imports nothing of jaxnav outside this subpackage (a contract in pyproject.toml checks it)."""
