"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.sweep.metrics`."""

from jaxstiff.sweep.metrics import METRICS as METRICS
from jaxstiff.sweep.metrics import csc_row_metrics as csc_row_metrics
from jaxstiff.sweep.metrics import shape_row_metrics as shape_row_metrics
