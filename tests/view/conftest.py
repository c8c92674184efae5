"""Fixtures of the viewer tests: result files built from arrays (tests/view/viewer_files.py)."""

from __future__ import annotations

import pytest
from viewer_files import make_csc_file, make_shape_result

import jaxstiff


@pytest.fixture(scope="module")
def lwr() -> jaxstiff.Robot:
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})


@pytest.fixture
def shape_file(tmp_path, lwr) -> str:
    return make_shape_result(lwr, 1, 8).save(str(tmp_path / "shape.npz"))


@pytest.fixture
def batch_file(tmp_path, lwr) -> str:
    return make_shape_result(lwr, 3, 6, seed=2, rigid=True).save(str(tmp_path / "batch.npz"))


@pytest.fixture
def csc_file(tmp_path, lwr) -> str:
    return make_csc_file(lwr, str(tmp_path / "csc.npz"), B=2)
