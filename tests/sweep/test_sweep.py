"""Sweeps end to end on tiny configs: the table against independent numpy re-computations and a
bare shape() call; interrupt (Ctrl-C in process, SIGKILL of a subprocess) + resume == uninterrupted
with no finished chunk recomputed; 2 simulated CPU devices and a local Ray instance give the same
table as the local run; the store refuses what it must; the CLI validates before any work."""

from __future__ import annotations

import hashlib
import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest
from helpers import CSC_TOML, REPO_ROOT, planar_arc_sweep

import jaxstiff
from jaxstiff.results._files import ShapeResult, is_usable, np_jacobian_rows, np_translational_stiffness, verify
from jaxstiff.sweep import run_sweep
from jaxstiff.sweep._config import kxd_matrix, parse_config
from jaxstiff.sweep._store import SweepStore, read_table

REPO = str(REPO_ROOT)


SHAPE_CFG = planar_arc_sweep(
    "tiny-shape", {"task": "xy", "criterion": "f2", "ratio": [2.0, 3.0], "dk": [5.0, 10.0], "first_starts": 2}
)


def _frame_equal(a: pd.DataFrame, b: pd.DataFrame) -> None:
    pd.testing.assert_frame_equal(a.reset_index(drop=True), b.reset_index(drop=True), check_exact=True)


def _frame_close(a: pd.DataFrame, b: pd.DataFrame, rtol: float, atol: float) -> None:
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    for c in a.columns:
        if a[c].dtype.kind == "f":
            np.testing.assert_allclose(a[c].to_numpy(), b[c].to_numpy(), rtol=rtol, atol=atol, err_msg=c)
        else:
            assert a[c].tolist() == b[c].tolist(), c


def _files_state(folder: str) -> dict[str, tuple[int, str]]:
    out = {}
    for f in sorted(os.listdir(folder)):
        p = os.path.join(folder, f)
        with open(p, "rb") as fh:
            out[f] = (os.stat(p).st_mtime_ns, hashlib.sha256(fh.read()).hexdigest())
    return out


@pytest.fixture(scope="module", autouse=True)
def _no_compile_cache():
    """Hermetic tests: no persistent compilation cache in ~/.cache (subprocesses inherit this)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("JAXSTIFF_COMPILE_CACHE", "0")
        yield


@pytest.fixture(scope="module")
def shape_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("shape") / "run"
    res = run_sweep(SHAPE_CFG, out, progress=False)
    return res


@pytest.fixture(scope="module")
def csc_cfg(tmp_path_factory):
    d = tmp_path_factory.mktemp("csccfg")
    f = d / "tiny_csc.toml"
    f.write_text(CSC_TOML, encoding="utf-8")
    return str(f)


@pytest.fixture(scope="module")
def csc_run(csc_cfg, tmp_path_factory):
    out = tmp_path_factory.mktemp("csc") / "run"
    return run_sweep(csc_cfg, out, progress=False)


# ---------------------------------------------------------------------------- shape sweeps
def test_shape_table_rows_and_settings(shape_run):
    df = shape_run.table()
    plan = shape_run.plan
    assert len(df) == plan.n_rows == 8
    assert df["row_id"].tolist() == list(range(8))
    # setting-major order: (ratio, dk) product x 2 paths
    want = [(r, k, p) for r in (2.0, 3.0) for k in (5.0, 10.0) for p in ("arc(radius=1.5)", "arc(radius=2)")]
    assert list(zip(df["ratio"], df["dk"], df["path"], strict=True)) == want
    assert set(df["criterion"]) == {"f2"} and set(df["task"]) == {"xy"}
    assert not any(c.endswith("time_s") or c == "wall_s" for c in df.columns)
    # the start posture's IK error is a column (the docs and the IK warning name it; it was only in
    # the chunk files): here the IK reaches the first waypoint, so it is below the IK tolerance
    from jaxstiff.sweep._run import IK_TOL_M

    assert df["q0_ik_error_m"].dtype == np.float64 and np.all(df["q0_ik_error_m"] < IK_TOL_M)


def test_shape_rows_verified_from_files_alone(shape_run):
    """Each row's arrays pass the numpy verification, and its metrics follow from numpy-recomputed
    ratio and alpha (not from the JAX kernel)."""
    df = shape_run.table()
    robot = shape_run.plan.robot
    for row in df.itertuples():
        full = ShapeResult.load(os.path.join(shape_run.out, row.result_file))
        chk = verify(full, robot=robot)
        assert chk["max_pos_error"] <= 1e-6 and chk["max_bound_violation"] <= 1e-9 and chk["max_rate_violation"] <= 1e-9
        b = row.result_index
        assert full.meta["ratio"] == row.ratio and full.meta["limits"]["dk"][0] == row.dk
        K = np.stack([np_translational_stiffness(robot, full.q[b, p], full.kj[b, p], "xy") for p in range(full.P)])
        w, V = np.linalg.eigh(K)
        rho = w[:, -1] / w[:, -2]
        d = full.direction[b, :, :2]
        alpha = np.degrees(np.arccos(np.clip(np.abs(np.sum(V[:, :, -1] * d, axis=1)), 0.0, 1.0)))
        usable = is_usable(full.status[b])
        r_ok = np.abs(rho - row.ratio) / row.ratio < 0.02
        a_ok = alpha < 1.0
        assert row.share_ratio == pytest.approx(np.mean(usable & r_ok), abs=1e-12)
        assert row.share_alpha == pytest.approx(np.mean(usable & a_ok), abs=1e-12)
        assert row.share_both == pytest.approx(np.mean(usable & a_ok & r_ok), abs=1e-12)
        assert row.share_usable == pytest.approx(np.mean(usable), abs=1e-12)
    assert df["share_usable"].min() > 0  # the tiny problem is solvable at least in part


def test_shape_row_equals_bare_shape_call(shape_run):
    """A sweep row is the same problem as calling jaxstiff.shape with those settings."""
    df = shape_run.table()
    row = df[(df["ratio"] == 3.0) & (df["dk"] == 10.0) & (df["path_index"] == 1)].iloc[0]
    got = ShapeResult.load(os.path.join(shape_run.out, row["result_file"]))
    # the same batch of paths as the sweep's call (shape's extra first-waypoint starts are drawn
    # from one generator across the batch, so a path's result depends on its batch position)
    trajs = [
        shape_run.plan.trajectories[i]
        for i in (df[df["result_file"] == row["result_file"]].sort_values("result_index")["path_index"])
    ]
    batch = jaxstiff.paths.Path(np.stack([t.points for t in trajs]), np.stack([t.directions for t in trajs]))
    ref = jaxstiff.shape(shape_run.plan.robot, batch, "f2", 3.0, task="xy", dk=10.0, first_starts=2)
    assert got.B == ref.B == len(trajs)
    np.testing.assert_array_equal(got.status, ref.status)
    np.testing.assert_allclose(got.q, ref.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.kj, ref.kj, rtol=0, atol=1e-9)


def test_shape_report_written(shape_run):
    md = open(os.path.join(shape_run.out, "summary.md"), encoding="utf-8").read()
    assert "**8**" in md and "## By ratio" in md and "## By dk" in md
    pngs = sorted(os.listdir(os.path.join(shape_run.out, "plots")))
    assert pngs == ["heatmap_share_both_dk_vs_ratio.png", "heatmap_share_ratio_dk_vs_ratio.png"]
    for p in pngs:
        assert f"plots/{p}" in md
        with open(os.path.join(shape_run.out, "plots", p), "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"


def test_outcome_repr_is_a_short_summary(shape_run):
    """print(run_sweep(...)) dumped every array of the plan (9,347 characters for a 2-path sweep):
    a line with the rows, the axes varied, the chunks and where the table is."""
    text = repr(shape_run)
    assert len(text) < 400 and "\n" not in text and "array(" not in text
    assert text.startswith("SweepOutcome(shape sweep")
    assert f"{shape_run.n_rows} rows" in text and shape_run.table_file in text
    assert f"{shape_run.n_chunks} chunks" in text and str(shape_run) == text


def test_ctrl_c_then_resume_equals_uninterrupted(shape_run, tmp_path):
    out = tmp_path / "interrupted"
    n_chunks = len(shape_run.plan.chunks)
    assert n_chunks == 2

    def stop_after_first(cid):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(SHAPE_CFG, out, progress=False, on_commit=stop_after_first)
    assert not (out / "results.parquet").exists()
    assert sorted(os.listdir(out / "chunks")) == ["chunk-000000.json"]
    before = _files_state(out / "chunks")
    # a kill in the middle of a write leaves a temporary file: it must be cleaned, never read
    (out / "arrays" / ".tmp-deadbeef.npz").write_bytes(b"partial")
    res = run_sweep(SHAPE_CFG, out, resume=True, progress=False)
    assert res.skipped == (0,) and res.computed == (1,)
    after = _files_state(out / "chunks")
    assert after["chunk-000000.json"] == before["chunk-000000.json"]  # not rewritten
    assert not any(f.startswith(".tmp-") for f in os.listdir(out / "arrays"))
    _frame_equal(res.table(), shape_run.table())
    man = json.load(open(out / "manifest.json"))
    assert [r["status"] for r in man["runs"]] == ["interrupted", "finished"]
    assert man["runs"][0]["computed"] == [0] and man["runs"][1]["skipped"] == [0]


def test_store_refuses_reuse_other_sweeps_and_concurrency(shape_run, tmp_path):
    plan = shape_run.plan
    with pytest.raises(ValueError, match=r"already holds this sweep \(2 of 2 chunks done\); pass --resume"):
        SweepStore(shape_run.out, plan)
    other = parse_config({**SHAPE_CFG, "axes": {**SHAPE_CFG["axes"], "ratio": [2.0, 4.0]}})
    with pytest.raises(ValueError, match=r"holds a different sweep .*changed: axes.ratio\. Use"):  # (only it)
        SweepStore(shape_run.out, other, resume=True)
    # the refusal names only what the plan hash sees: another URDF content, not another folder
    import jaxstiff

    urdf_text = open(jaxstiff.robot_path("planar_3r"), encoding="utf-8").read()
    plans = []
    for sub, text in (("a", urdf_text), ("b", urdf_text.replace('upper="3.14159', 'upper="3.0', 1))):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / "arm.urdf").write_text(text, encoding="utf-8")
        plans.append(parse_config({**SHAPE_CFG, "robot": {"urdf": "arm.urdf"}}, base_dir=tmp_path / sub))
    assert text != urdf_text
    with SweepStore(tmp_path / "urdf_store", plans[0]):
        pass
    with pytest.raises(ValueError, match=r"changed: robot\.urdf_sha256\. Use"):
        SweepStore(tmp_path / "urdf_store", plans[1], resume=True)
    # a store set up but with no chunk done (a run stopped while it started): run again without --resume
    empty = tmp_path / "empty"
    with SweepStore(empty, plan):
        pass
    with SweepStore(empty, plan) as st:
        assert st.done == {}
    # a renamed config file renames the sweep (its label only): the error says how to continue
    renamed = parse_config({**SHAPE_CFG, "sweep": {**SHAPE_CFG["sweep"], "name": "renamed"}})
    with pytest.raises(
        ValueError,
        match=r"holds this sweep under another label \(sweep.name '.+', now 'renamed'.*set name = \".+\" in \[sweep\] to continue",
    ):
        SweepStore(shape_run.out, renamed, resume=True)
    # only the description changed: the message named sweep.name, unchanged ("'base', now 'base'")
    described = parse_config({**SHAPE_CFG, "sweep": {**SHAPE_CFG["sweep"], "description": "x"}})
    with pytest.raises(ValueError) as e:
        SweepStore(shape_run.out, described, resume=True)
    msg = str(e.value)
    assert "under another label (sweep.description '', now 'x')" in msg and "sweep.name" not in msg, msg
    assert 'set description = "" in [sweep] to continue it' in msg, msg
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty and holds no sweep"):
        SweepStore(foreign, plan)
    assert sorted(os.listdir(foreign)) == ["notes.txt"]  # refused before anything (the lock) was written
    fresh = tmp_path / "fresh"
    with SweepStore(fresh, plan):
        with pytest.raises(ValueError, match="another jaxstiff sweep is writing"):
            SweepStore(fresh, plan, resume=True)
    # --resume where no sweep is (a misspelt folder) starts a new one, and says so: it went silently
    # ("0 resumed"), and the user waited for a whole sweep computed again
    with pytest.warns(UserWarning, match=r"holds no sweep yet \(no plan.json\), so nothing is resumed"):
        with SweepStore(tmp_path / "misspelt", plan, resume=True) as st:
            assert st.done == {}


def test_lock_owner_record_is_removed_when_the_run_ends(shape_run, tmp_path):
    """A stale .lock.owner naming a process long gone stayed in every finished or interrupted store
    (found in a finished sweep folder): it is removed when the lock is released; one left by a
    killed run is harmless (the next run takes the lock and writes its own) and says it is stale."""
    from jaxstiff.sweep._store import OWNER_FILE

    assert not os.path.exists(os.path.join(shape_run.out, OWNER_FILE))  # a finished run
    out = tmp_path / "stopped"

    def stop(cid):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(SHAPE_CFG, out, progress=False, report=False, on_commit=stop)
    assert (out / "plan.json").exists() and not (out / OWNER_FILE).exists()  # an interrupted run
    (out / OWNER_FILE).write_text("pid 999999 on gone since 2020-01-01T00:00:00\n")  # as a killed run leaves it
    with SweepStore(out, shape_run.plan, resume=True):
        text = (out / OWNER_FILE).read_text()
        assert text.startswith(f"pid {os.getpid()} on ") and "stale" in text
        with pytest.raises(ValueError, match=rf"another jaxstiff sweep is writing .*\(pid {os.getpid()} on [^()]*\);"):
            SweepStore(out, shape_run.plan, resume=True)
    assert not (out / OWNER_FILE).exists()


def test_two_sweeps_started_at_once_on_a_new_folder_leave_the_winner_alone(shape_run, tmp_path, monkeypatch):
    """Two sweeps starting at the same moment on the same new folder (found by a concurrency
    audit: 7 of 8 such starts broke): the one that made the folder lost the lock to the other and,
    refused, deleted the winner's lock and owner record and then the folder. Played here in one
    process: the "other sweep" takes the lock (flock on its own file description) just after this
    store makes the folder. This store is refused with the lock message (not "holds no sweep",
    from the winner's temporary owner file), and the winner's lock, record and folder stay."""
    from filelock import FileLock

    from jaxstiff.sweep import _store
    from jaxstiff.sweep._store import LOCK_FILE, OWNER_FILE

    out = tmp_path / "raced"
    winner = FileLock(str(out / LOCK_FILE), timeout=0)
    made = _store.SweepStore._make_folder

    def make_then_lose_the_race(self):
        created = made(self)
        winner.acquire()
        (out / OWNER_FILE).write_text("pid 1 on other since now\n")
        (out / ".tmp-abc123.owner").write_text("pid 1 on other since now\n")  # its write in flight
        return created

    monkeypatch.setattr(_store.SweepStore, "_make_folder", make_then_lose_the_race)
    try:
        with pytest.raises(ValueError, match=r"another jaxstiff sweep is writing .*\(pid 1 on other since now\)"):
            SweepStore(out, shape_run.plan)
        assert sorted(os.listdir(out)) == sorted([LOCK_FILE, OWNER_FILE, ".tmp-abc123.owner"])
        assert winner.is_locked
    finally:
        winner.release()
    # a folder holding only such a temporary file and a free lock is taken (the check under the
    # lock sees what is there then)
    monkeypatch.setattr(_store.SweepStore, "_make_folder", made)
    (out / OWNER_FILE).unlink()
    (out / ".tmp-abc123.owner").unlink()
    with SweepStore(out, shape_run.plan) as st:
        assert st.done == {}


def test_start_posture_retries_a_failed_ik_and_reports_its_distance(monkeypatch):
    """q0 = "ik"/"random": an IK that ends off the first waypoint is retried from further drawn
    postures (the closest kept); one that never reaches it warns, naming the path, and the distance
    is the row's q0_ik_error_m (a failed IK was used silently before, its rows then "unreachable")."""
    import jaxstiff.ik as ik
    from jaxstiff.ik import nominal_posture
    from jaxstiff.sweep._run import IK_RETRIES, IK_TOL_M, Q0_CACHE, start_posture_and_error

    far = {
        **SHAPE_CFG,
        "paths": [{"generator": "point", "point": [5.0, 0.0, 0.0], "n": 3, "name": "far"}],
        "axes": {"task": "xy", "q0": ["ik", "random", "nominal"]},
    }
    plan = parse_config(far)
    Q0_CACHE.clear()
    for r, fam in enumerate(("ik", "random")):
        assert plan.row_settings(r)["q0"] == fam
        with pytest.warns(
            UserWarning,
            match=rf"path 'far' \(q0 = '{fam}'.*ends 2(\.\d+)? m from its first waypoint after {1 + IK_RETRIES} tries",
        ):
            q, err = start_posture_and_error(plan, r)
        # planar 3R with unit links reaches 3 m at most: the IK stops ~2 m short, at the limits
        assert 1.9 < err < 2.1 and np.all(q >= plan.robot.lower - 1e-12) and np.all(q <= plan.robot.upper + 1e-12)
    q, err = start_posture_and_error(plan, 2)
    assert math.isnan(err) and np.allclose(q, nominal_posture(plan.robot))

    # a first IK that fails and a retry that succeeds: the retry's posture is used
    near = parse_config({**SHAPE_CFG, "axes": {"task": "xy", "q0": "ik"}})
    calls = []
    good = np.array([0.3, 0.2, 0.1])

    def fake_ik(robot, target, q_start=None, iters=150, planar=False):
        calls.append(q_start)
        return (np.zeros(3), 0.5) if len(calls) == 1 else (good, 0.1 * IK_TOL_M)

    monkeypatch.setattr(ik, "ik_position", fake_ik)
    Q0_CACHE.clear()
    q, err = start_posture_and_error(near, 0)
    assert len(calls) == 2 and calls[0] is None and calls[1] is not None  # nominal first, then a drawn start
    assert np.array_equal(q, good) and err == 0.1 * IK_TOL_M
    Q0_CACHE.clear()


# ---------------------------------------------------------------------------- csc sweeps
@pytest.mark.slow
def test_csc_table_against_numpy(csc_run):
    df = csc_run.table()
    plan = csc_run.plan
    assert len(df) == 8 and df["row_id"].tolist() == list(range(8))
    robot = plan.robot
    for row in df.itertuples():
        z = np.load(os.path.join(csc_run.out, row.result_file), allow_pickle=False)
        i = row.result_index
        assert int(z["row_id"][i]) == row.row_id
        K = kxd_matrix("xy", 3000.0, 3.0, row.kxd_angle_deg)
        np.testing.assert_allclose(z["K_xd"][i], K, rtol=1e-15)
        J = np_jacobian_rows(robot, z["q"][i, -1])[:2]
        Kq = J.T @ K @ J
        u = math.sqrt(sum(Kq[a, b] ** 2 for a in range(3) for b in range(a + 1, 3)))
        assert row.u_end == pytest.approx(u, rel=1e-9)
        kj = np.clip(np.diag(Kq), 1.0, np.inf)
        KC = np.linalg.inv(J @ np.diag(1.0 / kj) @ J.T)
        assert row.frobenius_end == pytest.approx(np.linalg.norm(K - KC), rel=1e-7)
        assert row.u_reduction == pytest.approx(1.0 - row.u_end / row.u_start, rel=1e-12)
        assert row.max_tracking_error < 1e-4
    # the null-space motion lowers u from the IK start posture with every beta
    assert (df["u_reduction"] > 0).all()
    assert os.path.isfile(os.path.join(csc_run.out, "plots", "heatmap_u_reduction_kxd_angle_deg_vs_beta.png"))


def _subprocess_env(**extra) -> dict:
    env = dict(os.environ)
    env.pop("XLA_FLAGS", None)
    env.update(extra)
    env["PYTHONPATH"] = REPO + os.pathsep + env.get("PYTHONPATH", "")
    return env


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")
def test_two_devices_give_the_same_table(csc_cfg, csc_run, tmp_path):
    import jax

    assert jax.local_device_count() == 1
    out = tmp_path / "two"
    env = _subprocess_env(XLA_FLAGS="--xla_force_host_platform_device_count=2")
    p = subprocess.run(
        [sys.executable, "-c", _CLI, "sweep", csc_cfg, "--out", str(out), "--no-progress", "--no-report"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    timing = pd.read_csv(out / "timing.csv")
    assert set(timing["devices"]) == {2}  # every batch was split across both devices
    assert set(pd.read_csv(os.path.join(csc_run.out, "timing.csv"))["devices"]) == {1}
    # XLA vectorises a per-device batch of 1 differently from a batch of 2: the floats may differ
    # in the last bit (measured: <= 2e-16 relative); everything else is identical
    _frame_close(read_table(out), csc_run.table(), rtol=1e-13, atol=1e-15)


_CLI = "import sys; from jaxstiff.cli import main; sys.exit(main())"

_KILL_DRIVER = """
import sys, time
from jaxstiff.sweep import run_sweep
run_sweep(sys.argv[1], sys.argv[2], progress=False, report=False, on_commit=lambda c: time.sleep(0.4))
"""


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")
def test_sigkill_midway_then_resume(csc_cfg, csc_run, tmp_path):
    out = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILL_DRIVER, csc_cfg, str(out)],
        env=_subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    chunks = out / "chunks"
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:
        if chunks.is_dir() and len([f for f in os.listdir(chunks) if f.startswith("chunk-")]) >= 2:
            break
        time.sleep(0.05)
    assert proc.stderr is not None
    assert proc.poll() is None, "the sweep ended before it could be killed: " + proc.stderr.read().decode()[-2000:]
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    proc.stderr.close()
    done_before = sorted(f for f in os.listdir(chunks) if f.startswith("chunk-"))
    assert 2 <= len(done_before) < 4
    before = _files_state(chunks)
    res = run_sweep(csc_cfg, out, resume=True, progress=False)
    ids_before = [int(f[6:12]) for f in done_before]
    assert list(res.skipped) == ids_before
    assert sorted(res.computed) == sorted(set(range(4)) - set(ids_before))  # no finished chunk recomputed
    after = _files_state(chunks)
    assert all(after[f] == before[f] for f in done_before)
    assert not any(f.startswith(".tmp-") for f in after)
    _frame_equal(res.table(), csc_run.table())


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")
def test_ray_backend_gives_the_same_table(csc_cfg, csc_run, tmp_path, monkeypatch):
    ray = pytest.importorskip("ray")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # a local test instance needs no token
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, runtime_env={"env_vars": {"PYTHONPATH": REPO}})
    try:
        res = run_sweep(csc_cfg, tmp_path / "ray", backend="ray", progress=False, report=False)
    finally:
        ray.shutdown()
    assert sorted(res.computed) == [0, 1, 2, 3]
    workers = set(pd.read_csv(tmp_path / "ray" / "timing.csv")["worker"])
    assert str(os.getpid()) not in {w.rsplit(":", 1)[1] for w in workers}  # computed by Ray workers
    _frame_equal(res.table(), csc_run.table())


# ---------------------------------------------------------------------------- command line
def test_cli_validates_before_any_work(tmp_path, capsys):
    from jaxstiff.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text('[robot]\nname = "planar_3r"\n[[paths]]\ngenerator = "default"\nn = 5\n[axes]\nratio = []\n')
    out = tmp_path / "never"
    assert main(["sweep", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "jaxstiff: error:" in err and "axes.ratio: empty axis" in err
    assert not out.exists()
    good = tmp_path / "good.toml"
    good.write_text(
        '[robot]\nname = "planar_3r"\n[[paths]]\ngenerator = "point"\npoint = [1.0, 1.0, 0.0]\nn = 3\n'
        '[axes]\ntask = "xy"\nratio = [2.0, 3.0]\n'
    )
    assert main(["sweep", str(good), "--out", str(out), "--dry-run"]) == 0
    assert "2 rows = 2 settings x 1 paths" in capsys.readouterr().out
    assert not out.exists()
    assert main(["sweep", str(good), "--out", str(out), "--backend", "ray", "--ray-num-cpus", "0"]) == 2


def test_cli_sigterm_is_an_interrupt_with_exit_143(tmp_path, capsys, monkeypatch):
    """SIGTERM (a scheduler's kill) stops a sweep like Ctrl-C: the resume hint, exit 143 (not the
    generic 'after the work had finished' message of the command line)."""
    import threading

    import jaxstiff.sweep as sweep_mod
    from jaxstiff.cli import main

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers can only be installed in the main thread")

    def killed(*a, **k):
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not interrupt")

    monkeypatch.setattr(sweep_mod, "run_sweep", killed)
    good = tmp_path / "good.toml"
    good.write_text(
        '[robot]\nname = "planar_3r"\n[[paths]]\ngenerator = "point"\npoint = [1.0, 1.0, 0.0]\nn = 3\n'
        '[axes]\ntask = "xy"\nratio = [2.0, 3.0]\n'
    )
    assert main(["sweep", str(good), "--out", str(tmp_path / "out")]) == 143
    err = capsys.readouterr().err
    assert "interrupted; finished chunks are saved" in err and "--resume" in err and "after the work" not in err


def test_heatmap_of_an_all_nan_metric_is_written_without_warnings(tmp_path):
    """A metric with no finite value (e.g. max_alpha_deg when no waypoint is usable): the cells say
    n/a, and matplotlib's 'identical low and high xlims' warnings (shown as jaxstiff warnings by
    the CLI) no longer appear."""
    import warnings

    from jaxstiff.sweep._report import heatmap

    plan = parse_config(SHAPE_CFG)
    df = pd.DataFrame({"ratio": [2.0, 2.0, 3.0, 3.0], "dk": [5.0, 10.0, 5.0, 10.0], "max_alpha_deg": [np.nan] * 4})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = heatmap(df, plan, "ratio", "dk", "max_alpha_deg", str(tmp_path / "h.png"))
    assert os.path.getsize(f) > 1000


def test_progress_note_says_saved_not_solved(csc_run):
    """The progress line counts waypoints as they are solved; its note counts rows and chunks as
    they are saved. A user saw "40/480 waypoints (rows 0/24, chunks 0/12)", interrupted, and found
    that chunk redone: the note now says those counts are the saved ones."""
    import io

    from jaxstiff.sweep._backends import Progress

    plan = csc_run.plan
    stream = io.StringIO()
    prog = Progress("t", plan, done_chunks=[0], enabled=True, stream=stream)
    first = plan.chunks[0]
    note = prog._note()
    assert note == f"saved: rows {len(first.rows)}/{plan.n_rows}, chunks 1/{len(plan.chunks)}", note
    prog.close()


def test_a_csc_sweep_from_the_nominal_posture_does_not_warn_per_chunk(tmp_path):
    """q0 family "nominal" starts off the path by the row's own choice: the rollout's far-start
    warning (another distance each chunk) is not repeated per chunk. The sweep's filters set "once"
    after its ignores, so the ignores were never reached (a warning filter added later is matched
    first): they are set the other way round now."""
    import warnings

    text = CSC_TOML.replace('step = "constant"', 'step = "constant"\nq0 = "nominal"')
    cfg = tmp_path / "nominal.toml"
    cfg.write_text(text, encoding="utf-8")
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        out = run_sweep(str(cfg), tmp_path / "run", progress=False)
    assert len(out.table()) == out.plan.n_rows
    assert not [w for w in rec if "start posture's TCP" in str(w.message)], [str(w.message) for w in rec]


def test_a_sweep_that_cannot_set_up_its_folder_says_nothing_was_kept(tmp_path, monkeypatch, capsys):
    """A full disk while the store is set up (its first file, the lock owner record): the command
    said "the chunks finished before it are kept in OUT ... --resume", about a folder it had just
    removed (found on a 60 KiB tmpfs). It now says the sweep did not start and how to run it again;
    a failure after the store exists keeps the resume advice."""
    import errno

    from jaxstiff.cli import main
    from jaxstiff.runtime import _io
    from jaxstiff.sweep import _store

    cfg = tmp_path / "tiny_csc.toml"
    cfg.write_text(CSC_TOML, encoding="utf-8")

    def full(path, text, *a, **k):
        raise _io.WriteError(f"cannot write {path}: no space left on device", errno.ENOSPC)

    monkeypatch.setattr(_store, "atomic_write_text", full)
    out = tmp_path / "new"
    assert main(["sweep", str(cfg), "--out", str(out), "--no-progress", "--no-report"]) == 1
    err = capsys.readouterr().err
    assert "no space left on device; the sweep did not start and left nothing in" in err, err
    assert "--resume" not in err and not out.exists()


def test_resume_by_other_code_is_said(shape_run, tmp_path):
    """A resumed sweep mixed chunks of two jaxstiff versions without a word (found in an interrupt
    audit: resumed after a code change, rows of one table came from different solvers). plan.json
    now records the code's sha256; a resume by other code warns, a resume by the same code does not."""
    import json
    import warnings

    out = tmp_path / "stopped"

    def stop(cid):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(SHAPE_CFG, out, progress=False, report=False, on_commit=stop)
    record = json.loads((out / "plan.json").read_text())
    assert len(record["code_sha256"]) == 64 and record["jaxstiff_version"] == jaxstiff.__version__
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same code: nothing to say
        with SweepStore(out, shape_run.plan, resume=True):
            pass
    record["code_sha256"] = "0" * 64
    (out / "plan.json").write_text(json.dumps(record))
    with pytest.warns(UserWarning, match=r"resume: the jaxstiff code differs from the code that started the sweep"):
        with SweepStore(out, shape_run.plan, resume=True):
            pass
