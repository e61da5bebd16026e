"""The robot side: NumPy-only policy inference (``deploy``) and the portable policy file.

``deploy`` imports neither JAX nor anything above :mod:`jaxnav.core`."""
