"""Bounded error messages: a list of names or a piece of input text is shown in part, with a count.

A URDF with 2,000,000 unconnected links once gave a 22.9 MB one-line error (every link named as a
root). Every message that lists names or quotes input goes through :func:`short_list` or
:func:`short_text`, so it stays readable whatever the input's size.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["LIST_LIMIT", "TEXT_LIMIT"]

LIST_LIMIT = 10  #: names shown before "... and N more"
TEXT_LIMIT = 80  #: characters of quoted input shown


def short_list(items: Iterable[object], limit: int = LIST_LIMIT, sep: str = ", ") -> str:
    """``"a, b, c"``, or the first ``limit`` items and ``"... and N more (M in all)"``.

    Example:
        >>> short_list([f"l{i}" for i in range(2_000_000)], 3)
        'l0, l1, l2, ... and 1999997 more (2000000 in all)'
    """
    seq = [str(x) for x in items]
    if len(seq) <= limit:
        return sep.join(seq)
    return f"{sep.join(seq[:limit])}, ... and {len(seq) - limit} more ({len(seq)} in all)"


def short_text(text: str, limit: int = TEXT_LIMIT) -> str:
    """``repr(text)``, cut to about ``limit`` characters with the full length stated."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"


def suggest(value: str, allowed: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for a near miss among ``allowed``, else ``""`` (difflib, cutoff 0.6)."""
    close = difflib.get_close_matches(str(value), [str(a) for a in allowed], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
