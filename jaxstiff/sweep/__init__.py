"""Parameter sweeps (``jaxstiff sweep CONFIG.toml``): :func:`run_sweep` runs a TOML config
(:func:`load_config`; every key documented in the private module ``_config``, which the docs' API
page shows whole) into a chunk store and returns a :class:`SweepOutcome`; :func:`read_table` reads
the table back; :data:`BACKENDS` names where chunks run; a bad config raises
:class:`SweepConfigError`. The code is in private modules: the config (``_config``, ``_schema``,
``_axes``, ``_axis_specs``), the plan (``_plan``), the run (``_run``, ``_chunks``, ``_starts``,
``_backends``), the store (``_store``, ``_stored``), per-row metrics (``_metrics``), the report
(``_report``)."""

from jaxstiff.runtime._moved import former_names

from ._config import load_config
from ._run import BACKENDS, SweepOutcome, run_sweep
from ._schema import SweepConfigError
from ._store import read_table

__all__ = [
    "BACKENDS",
    "SweepConfigError",
    "SweepOutcome",
    "load_config",
    "read_table",
    "run_sweep",
]

#: names this package exported for the former module ``sweep.py``, answered with a
#: DeprecationWarning naming the module that has them
_FORMER: dict[str, str] = dict.fromkeys(
    (
        "IK_RETRIES",
        "IK_TOL_M",
        "Progress",
        "compute_chunk",
        "default_cache_dir",
        "enable_compile_cache",
        "shard_batch",
        "start_posture",
        "start_posture_and_error",
    ),
    "jaxstiff.sweep._run",
)
__getattr__ = former_names(__name__, _FORMER)
