"""Gymnasium 1.x adapters (placeholder until the adapter module lands)."""


def register_envs() -> None:
    """Register every task under the ``hiddpg/`` namespace (not yet implemented)."""
