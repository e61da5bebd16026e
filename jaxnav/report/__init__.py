"""Results files, statistics, tables, the paper's claims and figures, all from files.

Never runs JAX, the environment or a network (contracts in pyproject.toml check it)."""
