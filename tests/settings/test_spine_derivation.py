"""The settings fields are the one place a setting is written (issue 38): a field added to
ShapeSettings or CSCSettings, with no other edit, is a flag of its command (default, help, value
read into the settings), a sweep axis accepted in the TOML (refused with a did-you-mean when
misspelt, and by the field's own check when out of range) and an entry of the result's
``meta["settings"]``.

The extra fields live in subclasses; the generators read them where the commands and the sweep
read the real classes (the module names are monkeypatched, the axis table rebuilt by
``sweep_axes``)."""

from __future__ import annotations

import argparse
import dataclasses
import math

import pytest

import jaxstiff
from jaxstiff.cli import _csc_flags as csc_flags
from jaxstiff.cli import _shape as shape_cmd
from jaxstiff.cli import _shape_flags as shape_flags
from jaxstiff.cli import build_parser
from jaxstiff.settings import CSCSettings, ShapeSettings
from jaxstiff.settings._base import positive, setting
from jaxstiff.sweep import _axis_specs as axis_specs
from jaxstiff.sweep._chunks import setting_values
from jaxstiff.sweep._config import AXES, SweepConfigError, parse_config

MARGIN_DOC = "room kept from the wrist's joint limits"
SETTLE_DOC = "steps the arm rests at the first target before it moves"


@dataclasses.dataclass(frozen=True)
class WiderShape(ShapeSettings):
    """ShapeSettings with one setting more."""

    wrist_margin: float = setting(0.25, unit="rad", doc=MARGIN_DOC, check=positive)


def _settle_check(v: object) -> str | None:
    return None if isinstance(v, int) and not isinstance(v, bool) and v >= 0 else "must be an integer >= 0"


@dataclasses.dataclass(frozen=True)
class WiderCSC(CSCSettings):
    """CSCSettings with one setting more."""

    settle_steps: int = setting(3, unit="steps", doc=SETTLE_DOC, check=_settle_check)


def _command(name: str) -> argparse.ArgumentParser:
    parser = build_parser(name)
    return parser._subparsers._group_actions[0].choices[name]  # type: ignore[union-attr]


def _action(p: argparse.ArgumentParser, flag: str) -> argparse.Action:
    return next(a for a in p._actions if flag in a.option_strings)


@pytest.fixture
def wider(monkeypatch):
    """The commands and the sweep see the classes with the extra fields."""
    monkeypatch.setattr(shape_flags, "ShapeSettings", WiderShape)
    monkeypatch.setattr(shape_cmd, "ShapeSettings", WiderShape)
    monkeypatch.setattr(csc_flags, "CSCSettings", WiderCSC)
    axes = axis_specs.sweep_axes(WiderShape, WiderCSC)
    monkeypatch.setitem(AXES, "shape", axes["shape"])
    monkeypatch.setitem(AXES, "csc", axes["csc"])


def test_a_new_shape_setting_is_a_flag_of_jaxstiff_shape(wider):
    p = _command("shape")
    act = _action(p, "--wrist-margin")
    assert act.default == 0.25 and act.dest == "wrist_margin"
    text = p.format_help()
    assert MARGIN_DOC in text and "rad" in (act.help or "") and "(default: 0.25)" in " ".join(text.split())
    args = p.parse_args(["--wrist-margin", "0.5"])
    values = shape_cmd._read_numbers(args)
    assert values["wrist_margin"] == 0.5
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})
    settings = shape_cmd._settings(args, values, robot)["settings"]
    assert isinstance(settings, WiderShape) and settings.wrist_margin == 0.5
    assert settings.meta()["wrist_margin"] == 0.5 and settings.meta()["units"]["wrist_margin"] == "rad"
    with pytest.raises(ValueError, match="--wrist-margin: expected a number, got 'wide'"):
        shape_cmd._read_numbers(p.parse_args(["--wrist-margin", "wide"]))
    with pytest.raises(ValueError, match=r"shape.wrist_margin \(rad\) must be a number > 0, got -1.0"):
        shape_cmd._settings(
            p.parse_args(["--wrist-margin", "-1"]),
            shape_cmd._read_numbers(p.parse_args(["--wrist-margin", "-1"])),
            robot,
        )
    # the settings' own flags are still there, with their defaults
    assert _action(p, "--dq-deg").default == 2.0 and _action(p, "--kmax").default == 100.0


def test_a_new_csc_setting_is_a_flag_of_jaxstiff_csc(wider):
    p = _command("csc")
    act = _action(p, "--settle-steps")
    assert act.default == 3 and act.type is int
    assert SETTLE_DOC in (act.help or "") and "steps" in (act.help or "")
    required = ["--hold", "0.5,0.2", "--kxd", "3000,1000", "--q0", "0,0,0", "--out", "x.npz"]
    settings = csc_flags.settings_from_args(p.parse_args([*required, "--settle-steps", "7"]))
    assert isinstance(settings, WiderCSC) and settings.settle_steps == 7
    assert settings.meta()["settle_steps"] == 7 and settings.meta()["units"]["settle_steps"] == "steps"
    default = csc_flags.settings_from_args(p.parse_args(required))
    assert isinstance(default, WiderCSC) and default.settle_steps == 3
    with pytest.raises(ValueError, match="--settle-steps must be an integer >= 0, got -2"):
        csc_flags.settings_from_args(p.parse_args([*required, "--settle-steps", "-2"]))


def _shape_cfg(**axes) -> dict:
    return {
        "sweep": {"kind": "shape", "name": "t"},
        "robot": {"name": "planar_3r"},
        "paths": [
            {"generator": "arc", "center": [0.0, 0.0, 0.0], "radius": 1.5, "start_deg": 10.0, "end_deg": 14.0, "n": 3}
        ],
        "axes": {"task": "xy", **axes},
    }


def _csc_cfg(**axes) -> dict:
    return {
        "sweep": {"kind": "csc"},
        "robot": {"name": "planar_3r"},
        "paths": [{"generator": "point", "point": [1.2, 1.0, 0.0], "n": 5}],
        "axes": {"task": "xy", **axes},
    }


def test_a_new_shape_setting_is_a_sweep_axis(wider):
    spec = AXES["shape"]["wrist_margin"]
    assert (spec.type, spec.default, spec.unit, spec.static) == ("float", 0.25, "rad", False)
    plan = parse_config(_shape_cfg(wrist_margin=[0.1, 0.2]))
    assert plan.axes["wrist_margin"] == [0.1, 0.2]
    assert sorted(s["wrist_margin"] for s in plan.settings) == [0.1, 0.2]
    # a row's settings as the chunk gives them to run_shape: the field is there
    row = WiderShape(**setting_values("shape", plan.settings[0]))
    assert row.wrist_margin == 0.1 and row.task == "xy" and row.dq == math.radians(2.0)
    assert parse_config(_shape_cfg()).axes["wrist_margin"] == [0.25]  # not given: the field's default
    with pytest.raises(SweepConfigError, match="did you mean 'wrist_margin'"):
        parse_config(_shape_cfg(wrist_margn=0.3))
    with pytest.raises(SweepConfigError, match=r"axes.wrist_margin: must be a number > 0, got -0.5"):
        parse_config(_shape_cfg(wrist_margin=[0.1, -0.5]))


def test_a_new_csc_setting_is_a_static_sweep_axis(wider):
    spec = AXES["csc"]["settle_steps"]
    assert (spec.type, spec.default, spec.unit, spec.static) == ("int", 3, "steps", True)
    plan = parse_config(_csc_cfg(settle_steps=[0, 4]))
    assert plan.axes["settle_steps"] == [0, 4]
    assert sorted(g["settle_steps"] for g in plan.groups) == [0, 4]  # static: one group per value
    assert setting_values("csc", plan.groups[0])["settle_steps"] in (0, 4)
    with pytest.raises(SweepConfigError, match="did you mean 'settle_steps'"):
        parse_config(_csc_cfg(setle_steps=1))
    with pytest.raises(SweepConfigError, match="axes.settle_steps: expected an integer"):
        parse_config(_csc_cfg(settle_steps=1.5))


def test_the_real_tables_have_no_extra_field():
    """Without the fixture the commands and the sweep have exactly the real fields (the fixture undid its patches)."""
    assert "wrist_margin" not in AXES["shape"] and "settle_steps" not in AXES["csc"]
    assert all("--wrist-margin" not in a.option_strings for a in _command("shape")._actions)
