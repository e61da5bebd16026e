"""A registered function given as itself or as ``"module:function"``, imported when first
used: how the strategy, agent and maze-family registries name code above ``core``
without importing it (so ``core`` imports no JAX)."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def resolve(ref: Callable[..., Any] | str) -> Callable[..., Any]:
    """``ref`` as a callable: itself, or the function a ``"module:function"`` names."""
    if callable(ref):
        return ref
    module, name = ref.split(":")
    return getattr(importlib.import_module(module), name)


__all__ = ["resolve"]
