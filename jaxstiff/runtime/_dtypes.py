"""One rule for the precision of inputs: half-precision floats are refused at the API boundaries.

float16 (and bfloat16, float8) inputs used to be accepted silently and computed with: an
ellipsoid volume of inf (65504 is float16's largest value), FK off by 0.9 mm. jaxstiff computes
in float64 (float32 allowed for throughput), so an input of a narrower float type is refused with
a message naming the argument; the caller converts it (``.astype(np.float64)``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["is_half_precision"]


def is_half_precision(dtype: Any) -> bool:
    """True for a floating dtype narrower than 32 bits (float16, bfloat16, the float8 types)."""
    try:
        dt = np.dtype(dtype)
    except TypeError:
        return False
    if dt.kind == "f":
        return dt.itemsize < 4
    # bfloat16 and float8 (ml_dtypes, as JAX registers them) are not numpy kind "f"
    return dt.itemsize < 4 and ("float" in dt.name)


def refuse_half_precision(where: str, **arrays: Any) -> None:
    """Raise ``ValueError`` if any of the named arrays (anything with a ``dtype``; lists and Python
    numbers are float64 and pass) is half precision.

    Args:
        where: the function, for the message (``"shape"``, ``"csc_rollout"``).
        **arrays: the inputs by argument name (None is skipped).

    Raises:
        ValueError: ``"shape: q0 has dtype float16 (half precision); ..."``.
    """
    for name, a in arrays.items():
        dt = getattr(a, "dtype", None)
        if dt is not None and is_half_precision(dt):
            raise ValueError(
                f"{where}: {name} has dtype {np.dtype(dt).name} (half precision), which loses about 1 mm in "
                "FK and overflows ellipsoid volumes; pass float32 or float64 (e.g. .astype(numpy.float64))"
            )
