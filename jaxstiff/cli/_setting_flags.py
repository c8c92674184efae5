"""The command-line flags of a settings class, made from its fields.

Each field of :class:`~jaxstiff.settings.ShapeSettings` / :class:`~jaxstiff.settings.CSCSettings`
with a :class:`~jaxstiff.settings._base.Flag` (every field unless ``flag=None``) becomes one flag of
its command: the flag's name (``--`` and the field's name, ``_`` as ``-``, unless the Flag names
it), its default (the field's, through ``Flag.from_field`` where the flag takes another unit), its
choices, its metavar and its help (the field's doc and unit, or the Flag's own text). A bool field
is a pair ``--name`` / ``--no-name``. Flags that are not settings (paths, ``--out``, ``--q0``, the
robot flags) are written by their commands.

Two ways of reading values: ``typed`` flags are converted by argparse (``jaxstiff csc``); the others
keep the text, which :func:`read_setting_flags` converts with an error naming the flag
(``jaxstiff shape``: ``--ratio: expected a number, got 'abc'``).
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import Any

from jaxstiff.settings._base import FieldInfo, Flag, Settings

__all__ = ["flag_name", "flag_help"]


def flag_name(info: FieldInfo) -> str:
    """The flag of a field with a :class:`Flag`: its own name, or ``--`` + the field's with ``-``."""
    flag = info.flag or Flag()
    return flag.name or "--" + info.name.replace("_", "-")


def _dest(info: FieldInfo) -> str:
    return flag_name(info).removeprefix("--").replace("-", "_")


def setting_flags(cls: type[Settings]) -> dict[str, str]:
    """``{field: flag}`` for every field of ``cls`` that has a flag, in field order."""
    return {i.name: flag_name(i) for i in cls.fields_info() if i.flag is not None}


def _shown(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def flag_help(info: FieldInfo, later: str | None = None) -> str:
    """The help of a field's flag: the Flag's own text, or ``"<doc>, <unit><extra>"`` (the flag's
    unit where it takes another one; a dimensionless "1" is not shown). ``later``: the command
    resolves the default itself; the help shows the field's default followed by ``later``."""
    flag = info.flag or Flag()
    if flag.help:
        text = flag.help
    else:
        unit = info.unit if flag.unit is None else flag.unit
        text = info.doc + (f", {unit}" if unit and unit != "1" else "") + flag.extra
    if later is not None:
        text += f" (default: {_shown(info.default)}{later})"
    elif "default" in text.lower() and "(default:" not in text and info.default is not None:
        # the help formatter adds no default to a text that speaks of one ("1 (default) keeps ...")
        text += f" (default: {_shown(info.default)})"
    return text


def add_setting_flags(
    p: argparse.ArgumentParser, cls: type[Settings], *, typed: bool, later: Mapping[str, str] | None = None
) -> None:
    """One flag per field of ``cls`` with a :class:`Flag` (see the module docstring).

    ``typed``: argparse converts the value to the field's type (else the text is kept for
    :func:`read_setting_flags`). ``later``: fields whose default the command resolves itself (the
    flag's value stays None when not given), each with the text its help shows after the default."""
    later = later or {}
    groups: dict[str, argparse._MutuallyExclusiveGroup] = {}
    for info in cls.fields_info():
        flag = info.flag
        if flag is None:
            continue
        where: Any = p
        if flag.group:
            if flag.group not in groups:
                groups[flag.group] = p.add_mutually_exclusive_group()
            where = groups[flag.group]
        name, dest = flag_name(info), _dest(info)
        default = info.default if flag.from_field is None else flag.from_field(info.default)
        if info.kind is bool:
            where.add_argument(name, dest=dest, action="store_true", help=flag_help(info))
            off = "--no-" + name.removeprefix("--")
            where.add_argument(off, dest=dest, action="store_false", help=flag.off_help or f"the opposite of {name}")
            p.set_defaults(**{dest: default})
            continue
        choices = flag.choices or info.choices
        kw: dict[str, Any] = {
            "default": None if info.name in later else default,
            "help": flag_help(info, later.get(info.name)),
            "type": flag.type or (info.kind if typed else None),
        }
        if choices is not None:
            kw["choices"] = [c for c in choices if c is not None]
        if flag.metavar is not None:
            kw["metavar"] = flag.metavar
        where.add_argument(name, dest=dest, **kw)


def _number(text: Any, flag: str, kind: type) -> Any:
    if text is None or not isinstance(text, str):
        return text
    try:
        return kind(text)
    except ValueError:
        what = "an integer" if kind is int else "a number"
        raise ValueError(f"{flag}: expected {what}, got {text!r}") from None


def read_setting_flags(args: argparse.Namespace, cls: type[Settings]) -> dict[str, Any]:
    """``{field: value}`` of every flag of ``cls`` in ``args``, in the field's unit (``Flag.to_field``):
    numbers given as text are converted, an error naming the flag (``--first-starts: expected an
    integer, got '2.5'``). A flag left None stays None (the field's default applies)."""
    out: dict[str, Any] = {}
    for info in cls.fields_info():
        if info.flag is None:
            continue
        v = getattr(args, _dest(info))
        if info.kind in (int, float):
            v = _number(v, flag_name(info), info.kind)
        if v is not None and info.flag.to_field is not None:
            v = info.flag.to_field(v)
        out[info.name] = v
    return out
