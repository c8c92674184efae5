"""Parameter sweeps: TOML config (:mod:`._config`), the run (:mod:`._run`), the chunk store
(:mod:`._store`), per-row metrics (:mod:`._metrics`), the report (:mod:`._report`).
``jaxstiff.sweep.X`` keeps working for every public name of the former ``sweep.py``."""

from ._config import load_config as load_config
from ._run import BACKENDS as BACKENDS
from ._run import IK_RETRIES as IK_RETRIES
from ._run import IK_TOL_M as IK_TOL_M
from ._run import Progress as Progress
from ._run import SweepOutcome as SweepOutcome
from ._run import compute_chunk as compute_chunk
from ._run import default_cache_dir as default_cache_dir
from ._run import enable_compile_cache as enable_compile_cache
from ._run import run_sweep as run_sweep
from ._run import shard_batch as shard_batch
from ._run import start_posture as start_posture
from ._run import start_posture_and_error as start_posture_and_error
from ._store import read_table as read_table
