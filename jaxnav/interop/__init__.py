"""Adapters to other frameworks: a Gymnasium ``Env`` of the environment."""
