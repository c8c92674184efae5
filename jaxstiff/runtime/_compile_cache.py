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

Every entry jaxstiff's processes write into JAX's cache carries a header with the key it was made
for and the sha256 of its bytes (:class:`CheckedCache`, installed by :func:`guard_jax_cache`):
JAX stores executables zstd-compressed without a checksum and hands them to XLA's deserializer,
so one flipped bit could crash the process or load another program. An entry that fails the
check is removed and compiled again, with one :class:`CacheDamageWarning`. The traced programs of
:mod:`jaxstiff.runtime._export_cache` use the same header (:func:`pack`, :func:`unpack`).
The cache only takes effect for programs compiled after it is turned on; turning it on after an
earlier compilation of the process re-arms JAX's cache (JAX decides once, at the first compilation,
whether a cache is in use).

:class:`CompileClock` measures how long JAX compiles while a block runs (what the commands print
and ``meta["timing_s"]["compile"]`` records); why it measures what it does: docs/notes/speed.md.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import threading
from collections.abc import Iterator
from typing import Any

__all__ = [
    "CacheDamageWarning",
    "CheckedCache",
    "guard_jax_cache",
    "CACHE_ENV",
    "CACHE_DIR_ENV",
    "CacheFolderWarning",
    "COMPILE_EVENTS",
    "MIN_COMPILE_S",
]

#: environment variable that turns the cache off (0, false, no, off)
CACHE_ENV = "JAXSTIFF_COMPILE_CACHE"
#: environment variable that moves the cache
CACHE_DIR_ENV = "JAXSTIFF_CACHE_DIR"
#: programs that compile faster than this (s) are not written to the cache (loading costs about as much)
MIN_COMPILE_S = 0.1

_OFF = ("0", "false", "no", "off")
_state: dict[str, str | None] = {}


# ---------------------------------------------------------------------- entries that check their bytes
#: first line of a cache entry written by jaxstiff (a traced program of
#: :mod:`jaxstiff.runtime._export_cache`, an executable of JAX's compilation cache); the header then
#: holds the key it was made for, the payload's sha256 and its length, each on its own line, and
#: the payload follows
MAGIC = b"jaxstiff-cache-entry 1\n"
#: a header longer than this is not one of ours (the key is at most a few hundred characters)
_HEADER_MAX = len(MAGIC) + 4096


class CacheDamageWarning(UserWarning):
    """A cached program (a traced program, or an entry of JAX's compilation cache) failed its
    checks and was discarded; the program is traced or compiled again (a cost, not a wrong result)."""


_WARNED: set[str] = set()


def warn_damaged(what: str, path: str, why: str) -> None:
    """One warning per process and cache kind: the damaged entry ``path`` was discarded (``why``)."""
    import warnings

    if what in _WARNED:
        return
    _WARNED.add(what)
    warnings.warn(
        f"{what} {path} is damaged ({why}); it was discarded and will be made again "
        "(results are not affected; further damaged entries are replaced without a warning)",
        CacheDamageWarning,
        stacklevel=2,
    )


def pack(file_key: str, payload: bytes) -> bytes:
    """A cache entry: :data:`MAGIC`, the file key, sha256 and length of ``payload``, ``payload``."""
    digest = hashlib.sha256(payload).hexdigest()
    return MAGIC + f"{file_key}\n{digest}\n{len(payload)}\n".encode() + payload


def unpack(data: bytes, file_key: str) -> bytes:
    """The payload of a cache entry made for ``file_key``, checked byte for byte; a
    ValueError saying what failed (magic, key, length, hash) for anything else. Nothing of the
    entry reaches jax's deserializers before this check (a damaged program can crash them)."""
    if not data.startswith(MAGIC):
        raise ValueError("no jaxstiff header")
    head = data[len(MAGIC) : _HEADER_MAX]
    lines = head.split(b"\n", 3)
    if len(lines) < 4:
        raise ValueError("header cut short")
    key, digest, length = (x.decode("ascii", "replace") for x in lines[:3])
    start = len(MAGIC) + sum(len(x) + 1 for x in lines[:3])
    if key != file_key:
        raise ValueError("made for another key")
    if not length.isdigit() or int(length) != len(data) - start:
        raise ValueError(f"length {len(data) - start} bytes, the header says {length!r}")
    payload = bytes(data[start:])
    if hashlib.sha256(payload).hexdigest() != digest:
        raise ValueError("sha256 of the program differs from its header")
    return payload


#: suffix of the keys under which :class:`CheckedCache` keeps JAX's entries: a plain JAX process
#: sharing the folder never reads one of them (it would not know the header), nor they its own
CHECKED_KEY_SUFFIX = "-jaxstiff-sha256"


def _cache_interface() -> type:
    try:
        from jax._src.compilation_cache_interface import CacheInterface  # noqa: PLC2701 - jax exports no cache interface to subclass
    except ImportError:  # pragma: no cover - another jax layout: a plain base
        return object
    return CacheInterface


class CheckedCache(_cache_interface()):  # type: ignore[misc]
    """JAX's persistent compilation cache with a sha256 per entry (the :func:`pack` header).

    JAX keeps a compiled executable zstd-compressed (zlib without zstandard) and hands the
    decompressed bytes to XLA's deserializer; zstd frames as JAX writes them carry no checksum,
    so a damaged entry can reach that deserializer (a crash no ``try`` catches, or another
    program). This wrapper of JAX's file cache checks each entry against its header before JAX
    sees it; one that fails is removed (JAX does not overwrite an existing entry) and reported as
    a miss, with one :class:`CacheDamageWarning` per process, and JAX compiles again.
    """

    def __init__(self, base: Any):
        self._base = base

    @property
    def _path(self) -> Any:  # (JAX reads the folder from here)
        return self._base._path

    @_path.setter
    def _path(self, value: Any) -> None:
        self._base._path = value

    def get(self, key: str) -> bytes | None:
        data = self._base.get(key + CHECKED_KEY_SUFFIX)
        if data is None:
            return None
        try:
            return unpack(data, key)
        except ValueError as e:
            where = os.path.join(os.fspath(self._path), f"{key}{CHECKED_KEY_SUFFIX}-cache")
            with contextlib.suppress(OSError):
                os.unlink(where)
            warn_damaged("the compilation cache entry", where, str(e))
            return None

    def put(self, key: str, value: bytes) -> None:
        self._base.put(key + CHECKED_KEY_SUFFIX, pack(key, bytes(value)))

    def clear(self) -> None:
        clear = getattr(self._base, "clear", None)
        if clear is not None:
            clear()


def guard_jax_cache() -> bool:
    """Make JAX's persistent compilation cache check its entries (:class:`CheckedCache`), now and
    after every re-initialisation (JAX builds its cache object lazily, in ``get_file_cache``).
    Idempotent; False where this JAX has no such hook (then its cache is used unchecked)."""
    try:
        from jax._src import compilation_cache as jcc  # noqa: PLC2701 - jax has no public hook on its file cache
    except ImportError:  # pragma: no cover
        return False
    make = getattr(jcc, "get_file_cache", None)
    if make is None:  # pragma: no cover - another jax layout
        return False
    if not getattr(make, "_jaxstiff_checked", False):

        def get_file_cache(path: str) -> Any:
            made = make(path)
            if made is None:
                return None
            cache, where = made
            inner = getattr(cache, "_base_cache", None)  # JAX's VerificationCache (check_contents) wraps the files
            if inner is not None and not isinstance(inner, CheckedCache):
                cache._base_cache = CheckedCache(inner)  # it compares JAX's own bytes: check below it
                return cache, where
            return CheckedCache(cache), where

        get_file_cache._jaxstiff_checked = True  # type: ignore[attr-defined]
        jcc.get_file_cache = get_file_cache
    current = getattr(jcc, "_cache", None)  # initialised before the hook: wrapped in place
    inner = getattr(current, "_base_cache", None)
    if inner is not None and not isinstance(inner, CheckedCache):
        current._base_cache = CheckedCache(inner)  # type: ignore[union-attr]
    elif current is not None and inner is None and not isinstance(current, CheckedCache):
        jcc._cache = CheckedCache(current)
    return True


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

    Left alone if the caller configured a cache of their own (that folder is returned). ``path``
    None turns off a cache that this module turned on. Returns the folder in use, or None
    (``path`` None, or the folder cannot be created or written).
    """
    import jax

    guard_jax_cache()  # whoever's folder it is: an entry is checked before XLA deserializes it
    current = getattr(jax.config, "jax_compilation_cache_dir", None)
    if current and current != _state.get("set"):
        return current  # the caller's own
    if path and current == path:
        return path
    if path:
        try:
            os.makedirs(path, exist_ok=True)
            if not os.access(path, os.W_OK):
                path = None
        except OSError:
            path = None
    if not path and not current:
        return None
    from jax.experimental.compilation_cache import compilation_cache

    jax.config.update("jax_compilation_cache_dir", path)
    if path:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", float(min_compile_s))
    # JAX decides at a process's first compilation whether a cache is in use and keeps that
    # answer: the folder changed, so let it decide again (the files on disk stay)
    compilation_cache.reset_cache()
    _state["set"] = path
    return path


class CacheFolderWarning(UserWarning):
    """The compilation cache folder the environment names cannot be made or written: the process
    runs without a persistent cache (every program compiles again; results are not affected)."""


def ensure_compile_cache(warn: bool = True) -> str | None:
    """:func:`enable_compile_cache` on :func:`default_cache_dir` (entry points call it; cheap when
    nothing changed: two environment look-ups). Returns the folder in use or None. ``warn``: a
    :class:`CacheFolderWarning`, once per folder, when the folder asked for cannot be used (a
    caller that reports it in its own words passes False)."""
    want = default_cache_dir()
    if "dir" not in _state or _state.get("want") != want:
        _state["want"] = want
        _state["dir"] = enable_compile_cache(want)
        if want and _state["dir"] is None and warn:
            import warnings

            source = f"${CACHE_DIR_ENV}" if os.environ.get(CACHE_DIR_ENV) == want else "the user cache folder"
            why = "a file, not a folder" if os.path.isfile(want) else "it cannot be made or written"
            warnings.warn(
                f"compilation cache folder {want} ({source}): {why}; running without a persistent "
                "compilation cache (every program compiles again in each process; results are not affected)",
                CacheFolderWarning,
                stacklevel=2,
            )
    return _state["dir"]


@contextlib.contextmanager
def compile_cache_flags(off: bool = False, path: str | None = None) -> Iterator[str | None]:
    """The commands' ``--no-compile-cache`` (``off``) and ``--compile-cache DIR`` (``path``) for the
    duration of a command: :data:`CACHE_ENV` / :data:`CACHE_DIR_ENV` set (child processes, e.g. a
    sweep's workers, inherit them; restored afterwards) and :func:`ensure_compile_cache` applied.
    Yields the folder in use or None."""
    saved = {k: os.environ.get(k) for k in (CACHE_ENV, CACHE_DIR_ENV)}
    if off:
        os.environ[CACHE_ENV] = "0"
    if path:
        os.environ[CACHE_DIR_ENV] = os.path.abspath(os.path.expanduser(path))
    try:
        yield ensure_compile_cache(warn=not path)  # a --compile-cache folder: the command says it
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def cache_dir_in_use() -> str | None:
    """The persistent cache folder JAX writes to now (None: no cache), whoever configured it."""
    import jax

    return getattr(jax.config, "jax_compilation_cache_dir", None) or None


#: the JAX events whose time spans make up compilation: tracing the Python function to a jaxpr,
#: lowering the jaxpr to StableHLO, and XLA's compile (or the load from the persistent cache)
COMPILE_EVENTS = (
    "/jax/core/compile/jaxpr_trace_duration",
    "/jax/core/compile/jaxpr_to_mlir_module_duration",
    "/jax/core/compile/backend_compile_duration",
)
_BACKEND_EVENT = COMPILE_EVENTS[2]
_HIT_EVENT = "/jax/compilation_cache/cache_hits"
_MISS_EVENT = "/jax/compilation_cache/cache_misses"


class CompileClock:
    """Wall time JAX spends compiling while a ``with`` block runs, from JAX's own monitoring events.

    ``seconds`` is the length of the union of the time spans of :data:`COMPILE_EVENTS` (tracing,
    lowering, XLA compile or cache load): a jit traced inside another one's trace is counted once,
    and compilations on other threads of the process count too. ``programs`` counts the XLA
    compilations (each either compiled or loaded from the persistent cache), ``cache_hits`` those
    loaded from it. Readable during and after the block; :meth:`seconds_between` gives the part of
    ``seconds`` inside a window of ``time.time()`` stamps.

    Example:
        >>> with CompileClock() as clock:  # doctest: +SKIP
        ...     f(x)
        >>> clock.seconds, clock.programs  # doctest: +SKIP
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._spans: list[tuple[float, float]] = []
        self.programs = 0
        self.cache_hits = 0
        self.cache_misses = 0

    def _on_span(self, event: str, start_time: float, end_time: float, **kwargs: Any) -> None:
        if event in COMPILE_EVENTS:
            with self._lock:
                self._spans.append((float(start_time), float(end_time)))
                self.programs += event == _BACKEND_EVENT

    def _on_event(self, event: str, **kwargs: Any) -> None:
        if event in (_HIT_EVENT, _MISS_EVENT):
            with self._lock:
                if event == _HIT_EVENT:
                    self.cache_hits += 1
                else:
                    self.cache_misses += 1

    def __enter__(self) -> CompileClock:
        from jax import monitoring

        monitoring.register_event_time_span_listener(self._on_span)
        monitoring.register_event_listener(self._on_event)
        return self

    def __exit__(self, *exc: object) -> None:
        from jax import monitoring

        monitoring.unregister_event_time_span_listener(self._on_span)
        monitoring.unregister_event_listener(self._on_event)

    def seconds_between(self, t0: float = float("-inf"), t1: float = float("inf")) -> float:
        """Seconds of compilation inside the window ``[t0, t1]`` (``time.time()`` stamps)."""
        with self._lock:
            spans = sorted((max(a, t0), min(b, t1)) for a, b in self._spans)
        total, end = 0.0, float("-inf")
        for a, b in spans:
            if b <= a or b <= end:
                continue
            total += b - max(a, end)
            end = b
        return total

    @property
    def seconds(self) -> float:
        """Seconds of compilation so far (union of the spans)."""
        return self.seconds_between()

    def meta(self) -> dict[str, Any]:
        """Counts and the cache folder, for a result's ``meta`` (times go to ``meta["timing_s"]``)."""
        return {
            "programs": self.programs,
            "cache_hits": self.cache_hits,
            "cache_misses": self.cache_misses,
            "cache_dir": cache_dir_in_use(),
            "measured": "union of the time spans of JAX's monitoring events " + ", ".join(COMPILE_EVENTS),
        }
