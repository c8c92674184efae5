"""Shared by the numbered examples: float64, the demo size and where figures go.

``JAXSTIFF_EXAMPLE_SIZE=tiny`` (the tests) shrinks every example to a few waypoints; the default
is a small but meaningful demo. ``JAXSTIFF_EXAMPLE_OUT`` moves the figures and files (default:
``docs/gallery/``, whose PNGs the documentation's gallery shows)."""

from __future__ import annotations

import os

import jax

jax.config.update("jax_enable_x64", True)  # float64: the solvers' tolerances are set for it
# many tiny SLSQP kernel calls: synchronous dispatch is faster on a CPU (the `shape` command does the same)
jax.config.update("jax_cpu_enable_async_dispatch", False)

TINY = os.environ.get("JAXSTIFF_EXAMPLE_SIZE", "") == "tiny"
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.environ.get("JAXSTIFF_EXAMPLE_OUT", os.path.join(HERE, "..", "docs", "gallery"))


def size(demo: int, tiny: int) -> int:
    """``demo`` normally, ``tiny`` under ``JAXSTIFF_EXAMPLE_SIZE=tiny``."""
    return tiny if TINY else demo


def figure(name: str) -> str:
    """The path of figure ``name`` (its folder created)."""
    os.makedirs(OUT, exist_ok=True)
    return os.path.join(OUT, name)
