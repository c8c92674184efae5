"""Every panel of a figure is big enough to read: a test that fails when an axes box is thinner than
MIN_SHARE of the drawn figure (its tight bounding box, what the PNG shows) in width or height.
Applied to the seven-panel path figure (``figure_shape_path``, whose panel (g) was a thin strip on
the default path, issue 40 item 4) and to the task-modes figure. Hand-made results, no solver run."""

from __future__ import annotations

import types

import numpy as np
import pytest
from helpers import numpy_fk

import jaxstiff
from jaxstiff.plots import _shape_path as shape_path
from jaxstiff.plots import _task_modes as task_modes

MIN_SHARE = 0.12  #: an axes box narrower or lower than this share of the drawn figure fails


def thin_panels(fig, min_share=MIN_SHARE):
    """``[(title, width share, height share)]`` of the panels (axes, colorbars left out) whose box
    is below ``min_share`` of the figure's drawn extent in width or height (after layout and aspect)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    tight = fig.get_tightbbox(renderer)  # inches
    fw, fh = fig.get_size_inches()
    bad = []
    for ax in fig.axes:
        if ax.get_label() == "<colorbar>":
            continue
        box = ax.get_position()  # figure fraction, after apply_aspect
        w, h = box.width * fw / tight.width, box.height * fh / tight.height
        if w < min_share or h < min_share:
            bad.append((ax.get_title() or ax.get_label(), round(w, 3), round(h, 3)))
    return bad


def _capture(monkeypatch, module):
    """Replace ``module.save_figure`` by one that keeps the figure's thin panels, then saves."""
    seen = {}
    original = module.save_figure

    def keep(fig, file, **kw):
        seen["thin"] = thin_panels(fig)
        seen["count"] = len(fig.axes)
        return original(fig, file, **kw)

    monkeypatch.setattr(module, "save_figure", keep)
    return seen


def _hand_made(robot, path, task="full"):
    """A one-path result on ``path`` (the plots read these fields): a fixed posture family, no solve."""
    P, n = len(path.points), robot.n
    q = np.deg2rad([10.0, 30.0, 0.0, -60.0, 0.0, 40.0, 0.0])[None] + np.linspace(0, 0.3, P)[:, None]
    q[:, 6] = 0.0  # lwr_a7 at its locked value
    kj = np.full((P, n), 50.0) + np.arange(n)
    kj[:, 6] = np.inf
    return types.SimpleNamespace(
        P=P, n=n, B=1, joint_names=np.array(robot.joint_names),
        meta={"ratio": 5.0, "criterion": "f2", "task": task},
        q=q[None], kj=kj[None], kj_scaled=2 * kj[None], cms=np.full((1, P), 2.0),
        target=np.asarray(path.points)[None], direction=np.asarray(path.directions)[None],
        position=np.stack([numpy_fk(robot, qi)[:3, 3] for qi in q])[None],
        criterion=np.full((1, P), 1.5), alpha_deg=np.linspace(0, 3, P)[None], ratio=np.linspace(3, 6, P)[None],
        status=np.zeros((1, P), int),
    )  # fmt: skip


@pytest.fixture(scope="module")
def lwr():
    return jaxstiff.Robot.from_urdf("kuka_lwr4", locked={"lwr_a7": 0.0})


def test_the_check_catches_a_thin_panel():
    plt = shape_path.pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"width_ratios": [1, 12]})
    assert [t for t, _, _ in thin_panels(fig)] == [a.get_label()]
    plt.close(fig)


@pytest.mark.parametrize("path_name", ["default", "line"])
def test_figure_shape_path_has_no_thin_panel(lwr, tmp_path, monkeypatch, path_name):
    """The default path is narrow in x (0.1 m by 0.5 m): an equal-aspect (g) shrank to a strip."""
    path = jaxstiff.default_path(n=20)
    if path_name == "line":
        path = jaxstiff.paths.line((0.5, -0.2, 0.3), (0.5, 0.2, 0.3), 20)
    seen = _capture(monkeypatch, shape_path)
    shape_path.figure_shape_path(_hand_made(lwr, path), lwr, tmp_path / "fig.png", "t", every=4, dpi=20)
    assert seen["count"] >= 7 and seen["thin"] == []


def test_figure_task_modes_has_no_thin_panel(lwr, tmp_path, monkeypatch):
    path = jaxstiff.default_path(n=20)
    seen = _capture(monkeypatch, task_modes)
    task_modes.figure_task_modes(
        _hand_made(lwr, path, "full"), _hand_made(lwr, path, "xyz"), lwr, tmp_path / "tm.png", "t", dpi=20
    )
    assert seen["count"] == 3 and seen["thin"] == []
