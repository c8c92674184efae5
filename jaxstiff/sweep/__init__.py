"""Parameter sweeps: TOML config (:mod:`.config`), the run (:mod:`.run`), the chunk store
(:mod:`.store`), per-row metrics (:mod:`.metrics`), the report (:mod:`.report`).
``jaxstiff.sweep.X`` keeps working for every public name of the former ``sweep.py``."""

from .config import load_config as load_config
from .run import BACKENDS as BACKENDS
from .run import IK_RETRIES as IK_RETRIES
from .run import IK_TOL_M as IK_TOL_M
from .run import Progress as Progress
from .run import SweepOutcome as SweepOutcome
from .run import compute_chunk as compute_chunk
from .run import default_cache_dir as default_cache_dir
from .run import enable_compile_cache as enable_compile_cache
from .run import run_sweep as run_sweep
from .run import shard_batch as shard_batch
from .run import start_posture as start_posture
from .run import start_posture_and_error as start_posture_and_error
from .store import read_table as read_table
