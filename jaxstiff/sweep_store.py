"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.sweep.store`."""

from jaxstiff.sweep.store import FORMAT as FORMAT
from jaxstiff.sweep.store import SweepStore as SweepStore
from jaxstiff.sweep.store import read_table as read_table
from jaxstiff.sweep.store import table_frame as table_frame
