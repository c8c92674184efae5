"""Former module path, kept so that old imports keep working: the code lives in :mod:`jaxstiff.stiffness.ellipsoid`."""

from jaxstiff.stiffness.ellipsoid import JACOBI_SWEEPS as JACOBI_SWEEPS
from jaxstiff.stiffness.ellipsoid import Ellipsoid as Ellipsoid
from jaxstiff.stiffness.ellipsoid import axis_ratio as axis_ratio
from jaxstiff.stiffness.ellipsoid import eigh_descending as eigh_descending
from jaxstiff.stiffness.ellipsoid import ellipsoid as ellipsoid
from jaxstiff.stiffness.ellipsoid import orientation_error as orientation_error
from jaxstiff.stiffness.ellipsoid import volume as volume
