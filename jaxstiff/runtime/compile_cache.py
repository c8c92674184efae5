"""JAX's persistent compilation cache, on by default for jaxstiff's commands, API and sweeps.

Compiling jaxstiff's kernels is most of what a short run waits for (the README main job: a few
seconds of compilation against well under a second of solving). With the cache, the second run
of the same shapes loads the compiled programs from disk instead of compiling them again. The cache
is keyed by the program (HLO, compiler options, backend, jaxlib version), so a stale entry is never
used, and a cache folder can be deleted at any time.

Where (first that applies):

* the caller configured a cache already (``jax.config.update("jax_compilation_cache_dir", ...)``
  or ``$JAX_COMPILATION_CACHE_DIR``): that one is used and nothing is changed;
* ``$JAXSTIFF_COMPILE_CACHE`` set to ``0``/``false``/``no``/``off``: no cache (the commands'
  ``--no-compile-cache`` sets it);
* ``$JAXSTIFF_CACHE_DIR``: that folder (the commands' ``--compile-cache DIR`` sets it);
* otherwise the user cache folder from platformdirs plus ``xla`` (Linux:
  ``$XDG_CACHE_HOME/jaxstiff/xla`` or ``~/.cache/jaxstiff/xla``; macOS:
  ``~/Library/Caches/jaxstiff/xla``; Windows: the local app data folder).

A folder that cannot be created or written is skipped silently (the run compiles as before).
"""

from __future__ import annotations

import os

__all__ = [
    "CACHE_ENV",
    "CACHE_DIR_ENV",
    "MIN_COMPILE_S",
    "default_cache_dir",
    "enable_compile_cache",
    "ensure_compile_cache",
]

#: environment variable that turns the cache off (0, false, no, off)
CACHE_ENV = "JAXSTIFF_COMPILE_CACHE"
#: environment variable that moves the cache
CACHE_DIR_ENV = "JAXSTIFF_CACHE_DIR"
#: programs that compile faster than this (s) are not written to the cache (loading costs about as much)
MIN_COMPILE_S = 0.1

_OFF = ("0", "false", "no", "off")
_state: dict[str, str | None] = {}


def default_cache_dir() -> str | None:
    """The cache folder the environment asks for (module docstring), or None when it turns the cache off."""
    if os.environ.get(CACHE_ENV, "1").strip().lower() in _OFF:
        return None
    d = os.environ.get(CACHE_DIR_ENV)
    if d:
        return d
    from platformdirs import user_cache_dir

    return os.path.join(user_cache_dir("jaxstiff", appauthor=False), "xla")


def enable_compile_cache(path: str | None, min_compile_s: float = MIN_COMPILE_S) -> str | None:
    """Turn on JAX's persistent compilation cache in ``path`` (a process-wide setting, like x64).

    Left alone if the caller already configured a cache (that folder is returned). Returns the folder
    in use, or None (``path`` None, or the folder cannot be created or written).
    """
    import jax

    current = getattr(jax.config, "jax_compilation_cache_dir", None)
    if current:
        return current
    if not path:
        return None
    try:
        os.makedirs(path, exist_ok=True)
        if not os.access(path, os.W_OK):
            return None
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float(min_compile_s))
    return path


def ensure_compile_cache() -> str | None:
    """:func:`enable_compile_cache` on :func:`default_cache_dir`, once per process (entry points call it)."""
    if "dir" not in _state:
        _state["dir"] = enable_compile_cache(default_cache_dir())
    return _state["dir"]
