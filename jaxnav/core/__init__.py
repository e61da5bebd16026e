"""Settings and command-line plumbing: config, settings, sweep axes, errors, start-up.

Imports no JAX (a contract in pyproject.toml checks it) and nothing else of jaxnav."""
