"""Traced programs kept on disk, so that a second run skips tracing as well as compiling.

JAX's persistent compilation cache (:mod:`jaxstiff.runtime._compile_cache`) skips XLA's compile,
but not the Python tracing that comes before it: for pgd's batch kernel (a scan over waypoints,
vmapped starts, unrolled kinematics) tracing and lowering take several seconds of every run, more
than the solve of a few paths. :func:`compile_with_export_cache` keeps the traced program
(``jax.export``'s serialized StableHLO) next to the compilation cache and, in a later process,
deserializes it instead of tracing; XLA's compile of it then comes from the compilation cache.

The file's name is a hash of everything the traced program depends on: the caller's key (the
problem's content fingerprint, the solver's settings), jaxstiff's source code (every ``.py`` file
of the package), the JAX and jaxlib versions, the backend, the input shapes and dtypes and the x64
flag. A caller whose program depends on something it cannot put in the key (a user's own
criterion function) passes ``key=None`` and gets the plain ``lower().compile()``.

A file holds a short header (:data:`~jaxstiff.runtime._compile_cache.MAGIC`, the file key it was made for, the sha256 and length of
the program's bytes) and the program; it is checked byte for byte before any of it reaches
``jax.export.deserialize`` (a damaged program can crash the deserializer, a segfault no
``try`` catches, or deserialize into another computation). A file that fails the check, cannot
be deserialized, or whose program does not lower and compile is removed, with one
:class:`CacheDamageWarning` per process, and the program is traced again and rewritten; a
folder that cannot be written only costs the tracing. Off where the compilation cache is off (``--no-compile-cache``,
``JAXSTIFF_COMPILE_CACHE=0``) and with ``JAXSTIFF_EXPORT_CACHE=0``.

The exported program is the same computation, compiled by the same XLA; every call of a kernel
goes through it while the cache is on (the first run too), so results do not depend on whether
the file was there.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxstiff.runtime._compile_cache import CacheDamageWarning, cache_dir_in_use, pack, unpack, warn_damaged

__all__ = [
    "CacheDamageWarning",  # (defined in compile_cache: both caches warn with it)
    "EXPORT_ENV",
    "EXPORT_SUBDIR",
    "arg_signature",
    "code_fingerprint",
    "export_dir",
]

#: environment variable that turns the traced-program cache off (0, false, no, off)
EXPORT_ENV = "JAXSTIFF_EXPORT_CACHE"
#: sub-folder of the compilation cache folder that holds the traced programs
EXPORT_SUBDIR = "jaxstiff-programs"

_OFF = ("0", "false", "no", "off")


def arg_signature(args: Sequence[Any]) -> tuple:
    """What a program compiled for ``args`` is specialised on, as a hashable key: the x64 flag, and
    per argument a numpy array's shape and dtype, a JAX array's shape, dtype, weak type and
    sharding, or any other value's type."""
    import jax

    sig: list[Any] = [bool(jax.config.read("jax_enable_x64"))]
    for a in args:
        if isinstance(a, np.ndarray):
            sig.append((0, a.shape, a.dtype))
        elif isinstance(a, jax.Array):
            sig.append((1, a.shape, a.dtype, a.weak_type, a.sharding))
        else:
            sig.append((2, type(a)))
    return tuple(sig)


@functools.cache
def code_fingerprint() -> str:
    """sha256 over jaxstiff's own source files (relative path and content, sorted by path)."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for p in sorted(root.rglob("*.py")):
        h.update(p.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def export_dir() -> str | None:
    """The folder for traced programs (a sub-folder of the compilation cache in use), or None."""
    if os.environ.get(EXPORT_ENV, "1").strip().lower() in _OFF:
        return None
    base = cache_dir_in_use()
    if not base or "://" in str(base):  # a remote cache (gs://...) has no local sub-folder
        return None
    return os.path.join(os.fspath(base), EXPORT_SUBDIR)


def _file_key(key: str, args: Sequence[Any]) -> str:
    import importlib.metadata

    import jax

    leaves = jax.tree_util.tree_leaves(args)
    shapes = [(tuple(getattr(a, "shape", ())), str(jax.numpy.result_type(a))) for a in leaves]
    parts = (
        key,
        code_fingerprint(),
        jax.__version__,
        importlib.metadata.version("jaxlib"),
        jax.default_backend(),
        repr(getattr(jax.config, "jax_enable_x64")),  # noqa: B009 - typed stubs lack the flags
        repr(getattr(jax.config, "jax_default_matmul_precision")),  # noqa: B009
        repr(jax.tree_util.tree_structure(args)),
        repr(shapes),
    )
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def _discard(path: str, why: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)
    warn_damaged("the cached traced program", path, why)


def _read(path: str, file_key: str) -> Any:
    """The exported program in ``path`` if the file is whole and made for ``file_key``, else None
    (a damaged file is removed, with one warning per process)."""
    from jax import export

    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:  # missing (the usual case), unreadable
        return None
    try:
        payload = unpack(data, file_key)
    except ValueError as e:
        _discard(path, str(e))
        return None
    try:
        return export.deserialize(bytearray(payload))
    except ImportError:  # no flatbuffers: no serialization
        return None
    except Exception as e:  # noqa: BLE001 - whole but foreign (another jax): trace again and replace it
        _discard(path, f"cannot be deserialized: {type(e).__name__}")
        return None


def _write(path: str, data: bytes) -> None:
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), prefix=".tmp-", suffix=".jaxexp")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)  # atomic: a reader sees the old file, the new one or none
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
    except OSError:
        pass  # an unwritable cache only costs the tracing next time


def _exported(fn: Any, args: Sequence[Any], key: str, fresh: bool = False) -> tuple[Any, str | None]:
    """The exported program of ``fn`` at ``args``, read from its file (unless ``fresh``) or traced
    and written; and the file's path when it was read from it (None: traced here)."""
    import jax
    from jax import export

    folder = export_dir()
    assert folder is not None
    file_key = _file_key(key, args)
    path = os.path.join(folder, file_key + ".jaxexp")
    exp = None if fresh else _read(path, file_key)
    if exp is not None:
        return exp, path
    exp = export.export(fn, platforms=[jax.default_backend()])(*args)
    with contextlib.suppress(ImportError):  # no flatbuffers: run the exported program unsaved
        _write(path, pack(file_key, bytes(exp.serialize())))
    return exp, None


def _compiled(fn: Any, args: Sequence[Any], key: str, opts: dict[str, Any] | None) -> tuple[Any, Any]:
    """``(jitted exported program, its compiled form for args)``: a program read from its file that
    fails to lower or compile (a foreign or damaged program that passed the checks) is discarded
    and traced again."""
    import jax

    exp, path = _exported(fn, args, key)
    jitted = jax.jit(exp.call, compiler_options=opts)
    if path is None:
        return jitted, jitted.lower(*args).compile()
    try:
        return jitted, jitted.lower(*args).compile()
    except Exception as e:  # noqa: BLE001 - the file's program only; a fresh trace's errors propagate
        _discard(path, f"does not compile: {type(e).__name__}")
    exp, _ = _exported(fn, args, key, fresh=True)
    jitted = jax.jit(exp.call, compiler_options=opts)
    return jitted, jitted.lower(*args).compile()


def compile_with_export_cache(
    fn: Any, args: Sequence[Any], key: str | None, compiler_options: dict[str, Any] | None = None
) -> Callable[..., Any]:
    """``fn`` (a ``jax.jit``-wrapped function) compiled for ``args``, through the traced-program cache.

    Args:
        fn: the jitted function.
        args: its positional arguments (arrays or numbers; their shapes and dtypes are in the key).
        key: everything else the traced program depends on, as a string (module docstring); None:
            no traced-program cache, ``fn.lower(*args).compile()``.
        compiler_options: XLA compiler options for the compile of the exported program (pass
            those ``fn`` was jitted with).

    Returns:
        The compiled function (call it with arguments of the same shapes and dtypes).
    """
    if key is None or export_dir() is None:
        return fn.lower(*args).compile()
    return _compiled(fn, args, key, compiler_options or None)[1]


class DiskJit:
    """A jitted function whose traced programs go through the traced-program cache: one program per
    argument signature (shapes, dtypes, numpy or JAX, x64), read from its file in a later process
    instead of traced. Called like the function (positional array arguments); the per-call cost
    is jit's own plus a signature look-up (10-25 us on a 2-core CPU; :meth:`specialize` skips it).

    Args:
        fn: the function (traceable; positional arguments only, arrays).
        key: what the program depends on besides jaxstiff's code and the signature (module
            docstring); None: a plain ``jax.jit``.
        compiler_options: XLA compiler options of every program.
    """

    def __init__(self, fn: Callable[..., Any], key: str | None, compiler_options: dict[str, Any] | None = None):
        import jax

        self._jit = jax.jit(fn, compiler_options=compiler_options or None)
        self._key = key
        self._opts = compiler_options or None
        self._by_sig: dict[tuple, Any] = {}

    def __call__(self, *args: Any) -> Any:
        return self.specialize(*args)(*args)

    def specialize(self, *args: Any) -> Callable[..., Any]:
        """The jitted function this object calls for arguments like ``args`` (read from its file or
        traced if needed). A hot loop that calls with one signature many times (an SLSQP solve:
        ~130 calls per waypoint) calls it directly and skips the per-call signature look-up;
        it accepts only arguments of that signature (shapes, dtypes, numpy or JAX, x64 flag)."""
        if self._key is None:
            return self._jit
        sig = arg_signature(args)
        f = self._by_sig.get(sig)
        if f is None:
            if export_dir() is None:
                f = self._jit
            else:
                # compiled now (the first call reuses it): a program from the file that fails
                # here is replaced by a fresh trace before anything runs it
                f = _compiled(self._jit, args, self._key, self._opts)[0]
            self._by_sig[sig] = f
        return f

    def _cache_size(self) -> int:
        """Programs compiled so far (jit's ``_cache_size``, for tests that count compilations)."""
        if self._key is None:
            return getattr(self._jit, "_cache_size")()  # noqa: B009 - private in the stubs
        return sum(f._cache_size() for f in {id(f): f for f in self._by_sig.values()}.values())
