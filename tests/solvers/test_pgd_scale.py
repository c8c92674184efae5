"""pgd solves a robot alike at any size (found by an independent check): its LM stage weighs
position errors (m) against dimensionless shape rows, and with a fixed weight per metre a planar 4R
with 10 m links ended at ratio 3 instead of 5 (status 0) while the 1 m arm was in target. The
weight is now per length unit of the robot (a power of two near :attr:`Chain.length_scale`)."""

from __future__ import annotations

import numpy as np
import pytest

import jaxstiff
from jaxstiff.solvers._pgd.kernel import length_unit


def planar_4r(tmp_path, link: float) -> jaxstiff.Robot:
    joints = "".join(
        f'<joint name="j{i + 1}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<origin xyz="{link if i else 0} 0 0"/><axis xyz="0 0 1"/>'
        f'<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        for i in range(4)
    )
    links = "".join(f'<link name="l{i}"/>' for i in range(5)) + '<link name="tool"/>'
    tool = f'<joint name="jt" type="fixed"><parent link="l4"/><child link="tool"/><origin xyz="{link} 0 0"/></joint>'
    f = tmp_path / f"planar_4r_{link:g}.urdf"
    f.write_text(f'<?xml version="1.0"?><robot name="p4">{links}{joints}{tool}</robot>')
    return jaxstiff.Robot.from_urdf(str(f))


def test_length_scale_and_unit():
    lwr = jaxstiff.Robot.from_urdf("kuka_lwr4")
    assert lwr.length_scale == pytest.approx(1.1785)
    assert length_unit(lwr.length_scale) == 1.0  # the LWR keeps lm_wpos exactly
    assert length_unit(40.0) == 32.0 and length_unit(0.004) == 2.0**-8


@pytest.mark.parametrize("link", [1.0, 10.0])
def test_pgd_is_in_target_at_every_size(tmp_path, link):
    robot = planar_4r(tmp_path, link)
    assert robot.length_scale == pytest.approx(4 * link)
    pts = np.linspace([2.2 * link, -0.3 * link, 0.0], [2.2 * link, 0.3 * link, 0.0], 5)
    res = jaxstiff.shape(robot, jaxstiff.Path(pts), "f2", 5.0, task="xy", solver="pgd", starts=2, dq=np.radians(15))
    assert np.all(res.status == 0)
    np.testing.assert_allclose(res.ratio, 5.0, rtol=1e-6)  # old code at 10 m: 3.06-3.33
    assert np.max(res.alpha_deg) < 1e-3
