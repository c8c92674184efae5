"""Opt-in float64 for entry points (CLI, experiments, scripts). The library never flips it at import."""

import jax


def enable_x64() -> None:
    """Switch JAX to 64-bit floats (solvers and verification need float64)."""
    jax.config.update("jax_enable_x64", True)
