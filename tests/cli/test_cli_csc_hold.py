"""``jaxstiff csc --hold`` without ``--step``: the constant step rule (the adaptive null step is beta
|dq_P|, zero while the target stands still), so the held arm moves in its null space and lowers u
while the TCP stays on the point; ``--step adaptive`` given explicitly still runs as asked (the
arm does not move) with its warning."""

from __future__ import annotations

import json

import numpy as np

import jaxstiff
from jaxstiff.cli import main

ARGV = ["csc", "--robot", "planar_3r", "--hold", "1.50005,0", "--kxd", "3000,1000@30"]
Q0_DEG = "75,-74.74,-76.30"


def _run(tmp_path, capsys, *extra):
    out = tmp_path / "hold.npz"
    rc = main([*ARGV, "--q0-deg", Q0_DEG, "--steps", "300", *extra, "--out", str(out)])
    err = capsys.readouterr().err
    with np.load(out, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files}
    return rc, err, data, json.loads(str(data["meta"]))


def test_hold_defaults_to_the_constant_step_and_moves_in_the_null_space(tmp_path, capsys):
    rc, err, f, meta = _run(tmp_path, capsys)
    assert rc == 0 and "step 'adaptive' on a held point" not in err
    assert meta["step"] == "constant" and meta["beta"] == 2e-3
    q0 = np.deg2rad([75.0, -74.74, -76.30])
    q = f["q"][0]
    # the joints move: 300 null steps of 2 mrad, the arm turned by far more than round-off ...
    assert np.max(np.abs(q[-1] - q0)) > 0.1
    # ... while the TCP stays on the point (FK of the recorded postures, not the file's own error)
    planar = jaxstiff.Robot.from_urdf("planar_3r")
    tcp = np.asarray(planar.fk(q))[:, :2, 3]
    assert np.max(np.linalg.norm(tcp - [1.50005, 0.0], axis=1)) < 1e-9
    assert f["u"][0, -1] < 0.9 * f["u_start"][0]  # and u goes down (S1-19; 21 % in 300 steps)


def test_hold_with_an_explicit_adaptive_step_runs_as_asked(tmp_path, capsys):
    rc, err, f, meta = _run(tmp_path, capsys, "--step", "adaptive")
    assert rc == 0 and meta["step"] == "adaptive" and meta["beta"] == 1.0
    # the library's warning (CSCWarning), once, with the command-line way out
    assert err.count("step 'adaptive' on a held point") == 1 and "--step constant" in err, err
    q0 = np.deg2rad([75.0, -74.74, -76.30])
    assert np.max(np.abs(f["q"][0, -1] - q0)) < 1e-3  # (only the first step's pull onto the point)


def test_hold_keeps_a_given_beta(tmp_path, capsys):
    rc, _, _, meta = _run(tmp_path, capsys, "--beta", "1e-3")
    assert rc == 0 and meta["step"] == "constant" and meta["beta"] == 1e-3
