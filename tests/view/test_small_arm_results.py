"""A result of an arm a few micrometres long (a case from an adversarial run): `jaxstiff.shape`
solved it, `ShapeResult.load` read it, but `plot`, `export` and `view` refused the file with "task
'full' leaves the compliance singular ... not the task the file was solved for". The reader judged
the 6 x 6 compliance's conditioning in SI units, where its translational rows (m/N) scale with
the arm's size squared against the rotational ones; it now judges it in the arm's own length
scale, which leaves K_T's axis ratio unchanged."""

from __future__ import annotations

import re

import numpy as np
import pytest
from viewer_files import make_shape_result

import jaxstiff
from jaxstiff.cli import main
from jaxstiff.model import robot_path
from jaxstiff.results._reader import COND_MAX, _compliance, _well_conditioned, read_result


def _scaled_lwr(tmp_path, s: float) -> str:
    """The shipped LWR's URDF with every origin offset times ``s`` (meshes dropped)."""
    with open(robot_path("kuka_lwr4")) as fh:
        text = fh.read()
    text = re.sub(r"<visual>.*?</visual>|<collision>.*?</collision>", "", text, flags=re.S)

    def scale(m: re.Match) -> str:
        return 'xyz="' + " ".join(f"{float(v) * s:.17g}" for v in m.group(1).split()) + '"'

    text = re.sub(r'xyz="([^"]*)"(?=[^>]*rpy|\s*/>)', scale, text)
    path = tmp_path / f"lwr_x{s:g}.urdf"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("s", [1e-5, 1.0, 100.0])
def test_a_result_reads_alike_at_any_arm_size(tmp_path, capsys, s):
    robot = jaxstiff.Robot.from_urdf(_scaled_lwr(tmp_path, s))
    assert robot.length_scale == pytest.approx(jaxstiff.Robot.from_urdf("kuka_lwr4").length_scale * s, rel=1e-9)
    file = make_shape_result(robot, 1, 4).save(str(tmp_path / "r.npz"))
    read_result(file)  # raised ResultFileError for s = 1e-5 before
    assert main(["export", file, "--csv", str(tmp_path / "r.csv")]) == 0, capsys.readouterr().err


def test_the_conditioning_is_judged_in_the_arm_length_scale():
    """The same posture and stiffness at two arm sizes: the SI condition number of the compliance
    grows by the size ratio squared; the judgement does not change."""
    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    rng = np.random.default_rng(0)
    q = robot.lower + (robot.upper - robot.lower) * rng.uniform(0.3, 0.7, (16, robot.n))
    kj = rng.uniform(5.0, 80.0, (16, robot.n))
    C = _compliance(robot, q, kj, "full")
    s = 1e-5
    d = np.r_[np.full(3, s), np.ones(3)]  # lengths times s: translational Jacobian rows times s
    C_small = C * d[:, None] * d[None, :]
    assert np.all(np.linalg.cond(C_small) > COND_MAX)  # the SI test called every one singular
    L = robot.length_scale
    assert np.array_equal(_well_conditioned(C, L), _well_conditioned(C_small, L * s))
    assert _well_conditioned(C_small, L * s).all()
