"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.sweep.report`."""

from jaxstiff.sweep.report import heatmap as heatmap
from jaxstiff.sweep.report import write_report as write_report
