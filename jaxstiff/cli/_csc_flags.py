"""The flags of ``jaxstiff csc`` that become values: ``--kxd`` (see :mod:`jaxstiff.cli._csc`) and the
:class:`~jaxstiff.settings.CSCSettings` flags (defaults, units and help from the settings fields)."""

from __future__ import annotations

import argparse
import math
import re

import numpy as np

from jaxstiff.cli._common import parse_floats
from jaxstiff.cli._setting_flags import add_setting_flags as add_settings_flags
from jaxstiff.cli._setting_flags import read_setting_flags, setting_flags
from jaxstiff.csc._inputs import check_kxd
from jaxstiff.settings._csc import CSCSettings

__all__ = ["flag_message"]

M_TASK = {2: "xy", 3: "xyz", 6: "full"}  #: the task of an m x m K_xd when --task is not given


def parse_numbers(text: str, flag: str) -> list[float]:
    """Comma-separated finite numbers of ``flag``; an error names the flag and the text."""
    vals = parse_floats(text, flag)
    if not vals or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"{flag}: expected finite comma-separated numbers, got {text!r}")
    return vals


def parse_kxd(text: str, task: str | None = None) -> np.ndarray:
    """``"K1,..,Km[@DEG]"`` or ``m*m`` numbers -> symmetric (m, m) matrix (N/m). See :mod:`jaxstiff.cli._csc`."""
    body, sep, deg = text.partition("@")
    vals = parse_numbers(body, "--kxd")
    want = None if task is None else {"xy": 2, "xyz": 3, "full": 6}[task]
    if sep:
        angle = parse_numbers(deg, "--kxd angle")
        if len(angle) != 1 or len(vals) not in (2, 3) or (want is not None and len(vals) != want):
            raise ValueError(
                f"--kxd {text!r}: the K1,...,Km@DEG form needs m = 2 or 3 diagonal values"
                + (f" (m = {want} for task {task!r})" if want else "")
                + " and one angle in degrees"
            )
        c, s = math.cos(math.radians(angle[0])), math.sin(math.radians(angle[0]))
        R = np.array([[c, -s], [s, c]]) if len(vals) == 2 else np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        K = R @ np.diag(vals) @ R.T
    elif len(vals) in (2, 3, 6) and (want is None or len(vals) == want):
        K = np.diag(vals)
    elif len(vals) in (4, 9, 36) and (want is None or len(vals) == want * want):
        m = int(round(math.sqrt(len(vals))))
        K = np.asarray(vals).reshape(m, m)
        unequal = np.argwhere(~np.isclose(K, K.T, rtol=1e-9, atol=1e-9))
        if unequal.size:
            i, j = (int(v) for v in unequal[0])
            raise ValueError(
                f"--kxd {text!r}: {len(vals)} numbers are read as a {m}x{m} matrix, row by row, and it is not "
                f"symmetric (row {i + 1}, column {j + 1}: {K[i, j]:g}; row {j + 1}, column {i + 1}: {K[j, i]:g}); "
                f"{m} numbers are the diagonal, {m * m} the whole matrix"
            )
    else:
        raise ValueError(
            f"--kxd {text!r}: give m diagonal values K1,...,Km[@DEG] or m*m matrix entries, m = 2, 3 or 6"
            + (f" (m = {want} for task {task!r})" if want else "")
            + f"; got {len(vals)} numbers"
        )
    try:  # csc_rollout's rule, its size limit first (eigenvalues of 1e308 entries overflow)
        check_kxd(K)
    except ValueError as e:
        raise ValueError(f"--kxd {text!r}: {e}") from None
    return K


#: the settings flags of `jaxstiff csc`: CSCSettings field -> flag (made from the fields: jaxstiff.cli._setting_flags)
SETTING_FLAGS = setting_flags(CSCSettings)


def add_setting_flags(p: argparse.ArgumentParser, later: dict[str, str] | None = None) -> None:
    """One flag per :class:`CSCSettings` field (:data:`SETTING_FLAGS`), its type, default, unit and
    doc from the field (:func:`jaxstiff.cli._setting_flags.add_setting_flags`, argparse converting).

    ``later``: fields whose default the command resolves itself (the flag's value stays None when
    not given), each with the text its help shows after the default (e.g. ``"; with --hold: constant"``)."""
    add_settings_flags(p, CSCSettings, typed=True, later=later)


def settings_from_args(args: argparse.Namespace) -> CSCSettings:
    """The :class:`CSCSettings` of the flags (a flag left None: the field's default); an error names
    the flag (``--kmin must be ...``)."""
    defaults = CSCSettings.defaults()
    values = {k: defaults[k] if v is None else v for k, v in read_setting_flags(args, CSCSettings).items()}
    try:
        return CSCSettings(**values)  # (kmin < kmax checked there, as csc_rollout and a csc sweep check it)
    except ValueError as e:
        raise ValueError(flag_message(str(e))) from None


def flag_message(msg: str) -> str:
    """``csc.kmin (Nm/rad) must be ...`` -> ``--kmin must be ... (Nm/rad)``: a field's name becomes
    its flag, and its unit, where the message gives it right after the name, moves to the end.
    Parentheses that are not the field's unit (values, as in ``csc.kmax (5) must be >= csc.kmin
    (10)``) stay where they are."""
    units = {i.name: i.unit for i in CSCSettings.fields_info()}
    moved: list[str] = []
    for name in sorted(units, key=len, reverse=True):  # longest first: no name is cut by a prefix
        flag = SETTING_FLAGS.get(name, "--" + name.replace("_", "-"))
        with_unit = f"csc.{name} ({units[name]})"
        if units[name] and with_unit in msg:
            msg = msg.replace(with_unit, flag)
            moved.append(units[name])
        msg = re.sub(rf"csc\.{name}\b", flag, msg)
    shown = [u for u in moved if u != "1"]  # "1": dimensionless, nothing to say
    return msg + (f" ({shown[0]})" if shown else "")
