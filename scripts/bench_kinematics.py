"""Benchmark: FK + geometric Jacobian of the shipped KUKA LWR 4 and of the third-party arms of
tests/data/robots, jaxstiff vs pytorch-kinematics.

Both libraries run side by side in one process on the same joint values (uniform inside the
joint limits), for each robot, batch size and dtype (the LWR first, as the yardstick):

* jaxstiff: ``jaxstiff.fk_and_jacobian(robot, q)`` (one jit-compiled pass, the pose (B, 4, 4) and
  J (B, 6, 7)) on JAX's default device.
* pytorch-kinematics: ``chain.jacobian(th, ret_eef_pose=True)`` (its fastest public call that
  returns both), on the CPU with ``torch.set_num_threads(<all cores>)``, chain moved to the dtype.

Compilation is timed apart from running: "first" is the first call (tracing + compilation + one
run; for pytorch-kinematics its warm-up call), "run" the median (and best) of repeated calls,
each ended with ``block_until_ready`` (JAX) - torch on the CPU is synchronous. Throughput is
configurations per second from the median; "vs pk" is jaxstiff / pytorch-kinematics and "vs LWR"
jaxstiff's throughput on the robot / on the LWR at the same batch and dtype; "kernel" the
kinematics kernel jaxstiff picks for the chain (``kernel_for``: unrolled, framed, scan). Each row
also records the largest difference between the two results (pytorch-kinematics parses URDF
numbers in float32, so ~1e-7 is agreement).

"ops" is a count that does not depend on the machine's load: the arithmetic operations per
configuration as XLA's CPU backend runs the unrolled kernels (:func:`entry_ops`). Their stacked
outputs are evaluated in one loop over the batch, each entry of the pose and the Jacobian from the
joint cosines and sines on its own, so the cost is the operations each entry depends on, summed
over the entries (docs/notes/model.md); "-" for the scan.

The process opts in to jaxstiff's allocator setting (``jaxstiff.runtime.tune_allocator()``, what
the ``jaxstiff`` command does and the docs tell a script with large batches to do; ``import
jaxstiff`` alone leaves glibc's defaults, about 2x slower at B = 1e5); ``--no-tune`` measures
without it.

Usage:
    python scripts/bench_kinematics.py --sizes 1e5             # every arm, float32 and float64
    python scripts/bench_kinematics.py --robot lwr              # the LWR alone (sizes 1, 1e3, 1e5, 1e6)
    python scripts/bench_kinematics.py --robot tests/data/robots/ur10.urdf --tip-link tool0
    python scripts/bench_kinematics.py --sizes 1,1000 --dtypes float64 --json out.json
    python scripts/bench_kinematics.py --no-torch               # jaxstiff only
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from typing import Any

DEFAULT_SIZES = (1, 1_000, 100_000, 1_000_000)
ROBOTS_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "tests", "data", "robots")
#: the arm's end link of each file of tests/data/robots (not a finger: the automatic choice may differ)
TIP_LINKS = {
    "kinova_j2s6s200.urdf": "j2s6s200_end_effector",
    "ur10.urdf": "tool0",
    "z1.urdf": "link06",
    "talos_left_arm.urdf": "arm_left_7_link",
    "so101.urdf": "gripper_frame_link",
}


def _sizes(text: str) -> list[int]:
    try:
        sizes = [int(float(v)) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sizes: expected comma-separated integers, got {text!r}") from None
    if not sizes or any(s < 1 for s in sizes):
        raise argparse.ArgumentTypeError(f"--sizes: every size must be >= 1, got {text!r}")
    return sizes


def _time_calls(call, first_seconds: float, min_time: float, max_repeats: int) -> list[float]:
    """Wall times of repeated calls: enough repeats to fill ``min_time`` (at least 3)."""
    repeats = max(3, min(max_repeats, int(min_time / max(first_seconds, 1e-7))))
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        out.append(time.perf_counter() - t0)
    return out


def entry_ops(robot, kernel: str) -> int | None:
    """Multiplications, additions, subtractions and negations per configuration that the entries of
    ``fk_and_jacobian`` depend on, summed over the entries of the pose and the Jacobian (the joint
    cosines and sines taken as given); None for the scan kernel (a loop, not straight-line code).

    Read from the traced program: every operand of an innermost stack of the outputs is one entry,
    and its cone is followed back to the cosines and sines."""
    import jax
    import jax.numpy as jnp

    from jaxstiff.model._kinematics import fk_and_jacobian_raw

    if kernel == "scan":
        return None
    jaxpr = jax.make_jaxpr(lambda q: fk_and_jacobian_raw(robot, q, poly=False, kernel=kernel))(
        jnp.zeros((2, robot.n))
    ).jaxpr
    producer = {v: e for e in jaxpr.eqns for v in e.outvars}
    arith = {"mul", "add", "sub", "neg"}
    cones: dict = {}

    def cone(v) -> frozenset:
        if v not in producer:  # a literal, a constant or q itself
            return frozenset()
        if v in cones:
            return cones[v]
        eqn = producer[v]
        out: frozenset = frozenset()
        if eqn.primitive.name not in ("sin", "cos"):
            for u in eqn.invars:
                if not hasattr(u, "val"):  # (a Literal carries its value)
                    out |= cone(u)
            if eqn.primitive.name in arith:
                out |= {id(eqn)}
        cones[v] = out
        return out

    stacking = ("stack", "concatenate")  # (JAX's jnp.stack is a primitive of its own in recent versions)
    stacks = [e for e in jaxpr.eqns if e.primitive.name in stacking]
    innermost = [
        e for e in stacks if not any(u in producer and producer[u].primitive.name in stacking for u in e.invars)
    ]
    return sum(len(cone(u)) for e in innermost for u in e.invars if not hasattr(u, "val"))


def bench_jaxstiff(robot, q_np, dtype_name, min_time, max_repeats, kernel=None):
    import jax
    import jax.numpy as jnp

    import jaxstiff
    from jaxstiff.model._kinematics import fk_and_jacobian_raw

    q = jax.block_until_ready(jnp.asarray(q_np, dtype=getattr(jnp, dtype_name)))
    if kernel is None:
        fn = jaxstiff.fk_and_jacobian
    else:  # a forced kernel, jitted as fk_and_jacobian is (before/after comparisons)
        forced = jax.jit(lambda x: fk_and_jacobian_raw(robot, x, kernel=kernel))

        def fn(_robot, x):
            return forced(x)

    def call():
        return jax.block_until_ready(fn(robot, q))

    t0 = time.perf_counter()
    T, J = call()
    first = time.perf_counter() - t0
    assert T.dtype == q.dtype and J.dtype == q.dtype
    # a first estimate of the run time decides the number of repeats
    t0 = time.perf_counter()
    call()
    one = time.perf_counter() - t0
    times = _time_calls(call, one, min_time, max_repeats)
    return first, times, (T, J)


def bench_torch(chain, q_np, dtype_name, min_time, max_repeats):
    import torch

    th = torch.tensor(q_np, dtype=getattr(torch, dtype_name))

    def call():
        with torch.no_grad():
            return chain.jacobian(th, ret_eef_pose=True)

    t0 = time.perf_counter()
    J, T = call()
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    call()
    one = time.perf_counter() - t0
    times = _time_calls(call, one, min_time, max_repeats)
    return first, times, (T, J)


def _versions() -> dict:
    import jax
    import jaxlib
    import numpy

    import jaxstiff

    v = {
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numpy": numpy.__version__,
        "jaxstiff": jaxstiff.__version__,
    }
    try:
        from importlib.metadata import version

        import torch

        v["torch"] = torch.__version__
        v["pytorch_kinematics"] = version("pytorch_kinematics")
    except Exception:  # noqa: BLE001 - the reference is optional
        pass
    return v


def _device() -> dict:
    import jax

    d = jax.devices()[0]
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "jax_backend": jax.default_backend(),
        "jax_device": getattr(d, "device_kind", str(d)),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
    }


def _fmt_rate(x):
    return "-" if x is None else f"{x:.3g}"


def _fmt_s(x):
    if x is None:
        return "-"
    if x < 1e-3:
        return f"{x * 1e6:.1f}us"
    if x < 1:
        return f"{x * 1e3:.2f}ms"
    return f"{x:.2f}s"


HEADER = (
    f"{'robot':<16} {'n':>2} {'kernel':>8} {'ops':>5} {'batch':>7} {'dtype':>7} | {'jx first':>9} {'jx run':>9} "
    f"{'jx cfg/s':>9} {'vs LWR':>6} | {'pk first':>9} {'pk run':>9} {'pk cfg/s':>9} | {'vs pk':>7} {'max|diff|':>9}"
)


def format_row(r: dict) -> str:
    ratio = "-" if r["ratio"] is None else f"{r['ratio']:.1f}x"
    diff = "-" if r["max_abs_diff"] is None else f"{r['max_abs_diff']:.1e}"
    lwr = "-" if r.get("vs_lwr") is None else f"{r['vs_lwr']:.2f}"
    return (
        f"{r['robot']:<16} {r['n']:>2} {r['kernel']:>8} {'-' if r.get('ops') is None else r['ops']:>5} "
        f"{r['batch']:>7} {r['dtype']:>7} | "
        f"{_fmt_s(r['jaxstiff_first_s']):>9} "
        f"{_fmt_s(r['jaxstiff_run_median_s']):>9} {_fmt_rate(r['jaxstiff_configs_per_s']):>9} {lwr:>6} | "
        f"{_fmt_s(r['torch_first_s']):>9} {_fmt_s(r['torch_run_median_s']):>9} "
        f"{_fmt_rate(r['torch_configs_per_s']):>9} | {ratio:>7} {diff:>9}"
    )


def _write_json(path: str, payload: dict) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".bench_kinematics.", suffix=".json", dir=folder)
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(payload, fh, indent=2)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _parse_args(argv: list[str] | None) -> tuple[argparse.Namespace, list[str]]:
    """The command line and the list of dtype names it asks for."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--robot",
        default="all",
        help='"all" (the LWR and every URDF of tests/data/robots), "lwr", or a URDF file (then also the LWR)',
    )
    ap.add_argument(
        "--kernel",
        default="auto",
        choices=("auto", "unrolled", "framed", "scan"),
        help="force this kinematics kernel on the robots other than the LWR (scan: the kernel before issue 37)",
    )
    ap.add_argument("--tip-link", default=None, help="tip link of --robot FILE (default: the table in the script)")
    ap.add_argument("--sizes", type=_sizes, default=list(DEFAULT_SIZES), help="comma-separated batch sizes")
    ap.add_argument("--dtypes", default="float32,float64", help="comma-separated: float32, float64")
    ap.add_argument("--min-time", type=float, default=1.0, help="seconds of timed calls per cell (at least 3 calls)")
    ap.add_argument("--max-repeats", type=int, default=2000, help="upper bound on timed calls per cell")
    ap.add_argument("--no-torch", action="store_true", help="skip pytorch-kinematics")
    ap.add_argument("--no-tune", action="store_true", help="leave glibc's allocator as import jaxstiff does")
    ap.add_argument("--json", default=None, metavar="FILE", help="write rows, device, versions and sizes here")
    args = ap.parse_args(argv)
    dtypes = [d.strip() for d in args.dtypes.split(",") if d.strip()]
    if not dtypes or any(d not in ("float32", "float64") for d in dtypes):
        ap.error(f"--dtypes: choose from float32, float64, got {args.dtypes!r}")
    return args, dtypes


def _torch_chain(robot):
    """pytorch-kinematics' serial chain of ``robot`` (same base and tip links; torch on all cores), or
    None if it is not installed."""
    try:
        import pytorch_kinematics as pk
        import torch
    except ImportError:
        print("pytorch-kinematics/torch not installed: jaxstiff only (pip install '.[ref]')", file=sys.stderr)
        return None
    torch.set_num_threads(os.cpu_count() or 1)
    import contextlib
    import io

    with (
        open(robot.source, "rb") as fh,
        contextlib.redirect_stdout(io.StringIO()),
        contextlib.redirect_stderr(io.StringIO()),
    ):
        return pk.build_serial_chain_from_urdf(
            fh.read(), robot.tip_link, robot.base_link
        )  # (its parser's warnings muted)


def _robots(which: str, tip_link: str | None) -> list[tuple[str, Any]]:
    """(label, Robot) to measure: the LWR first, then the chosen URDF(s)."""
    import jaxstiff

    out = [("kuka_lwr4", jaxstiff.Robot.from_urdf("kuka_lwr4"))]
    if which == "lwr":
        return out
    if which == "all":
        files = [os.path.join(ROBOTS_DIR, f) for f in sorted(os.listdir(ROBOTS_DIR)) if f.endswith(".urdf")]
    else:
        if not os.path.isfile(which):
            raise SystemExit(f"--robot: no such URDF file {which!r} (or use 'all' / 'lwr')")
        files = [which]
    for path in files:
        base = os.path.basename(path)
        tip = tip_link if (tip_link and which != "all") else TIP_LINKS.get(base)
        robot = jaxstiff.Robot.from_urdf(path, tip_link=tip)
        out.append((base.removesuffix(".urdf"), robot))
    return out


def _measure_cell(robot, pk_chain, q_np, dtype_name: str, args: argparse.Namespace) -> dict:
    """One row: jaxstiff (and pytorch-kinematics if ``pk_chain``) at one batch size and dtype."""
    import numpy as np

    from jaxstiff.model._kinematics_scan import kernel_for

    size = q_np.shape[0]
    kernel = None if args.kernel == "auto" or robot.name == "kuka_lwr4" else args.kernel
    first, times, (T, J) = bench_jaxstiff(robot, q_np, dtype_name, args.min_time, args.max_repeats, kernel)
    med = statistics.median(times)
    kernel_name = kernel_for(robot) if kernel is None else kernel
    row = {
        "n": robot.n,
        "tip_link": robot.tip_link,
        "kernel": kernel_name,
        "ops": entry_ops(robot, kernel_name),
        "batch": size,
        "dtype": dtype_name,
        "jaxstiff_first_s": first,
        "jaxstiff_run_median_s": med,
        "jaxstiff_run_best_s": min(times),
        "jaxstiff_repeats": len(times),
        "jaxstiff_configs_per_s": size / med,
        "torch_first_s": None,
        "torch_run_median_s": None,
        "torch_run_best_s": None,
        "torch_repeats": 0,
        "torch_configs_per_s": None,
        "ratio": None,
        "max_abs_diff": None,
    }
    if pk_chain is not None:
        tfirst, ttimes, (Tt, Jt) = bench_torch(pk_chain, q_np, dtype_name, args.min_time, args.max_repeats)
        tmed = statistics.median(ttimes)
        k = min(size, 1000)
        diff = max(
            float(np.max(np.abs(np.asarray(T[:k], dtype=float) - Tt[:k].numpy()))),
            float(np.max(np.abs(np.asarray(J[:k], dtype=float) - Jt[:k].numpy()))),
        )
        row.update(
            torch_first_s=tfirst,
            torch_run_median_s=tmed,
            torch_run_best_s=min(ttimes),
            torch_repeats=len(ttimes),
            torch_configs_per_s=size / tmed,
            ratio=(size / med) / (size / tmed),
            max_abs_diff=diff,
        )
    return row


def main(argv: list[str] | None = None) -> int:
    args, dtypes = _parse_args(argv)

    from jaxstiff.runtime import tune_allocator
    from jaxstiff.runtime._x64 import enable_x64

    tuned = False if args.no_tune else tune_allocator()
    print(f"allocator setting (jaxstiff.runtime.tune_allocator): {'on' if tuned else 'off'}")

    enable_x64()  # float64 available; float32 inputs stay float32 (the kernel keeps the dtype)
    import numpy as np

    robots = _robots(args.robot, args.tip_link)

    dev = _device()
    print(
        f"FK + Jacobian; jaxstiff on {dev['jax_backend']} ({dev['jax_device']}), "
        f"pytorch-kinematics on CPU ({os.cpu_count()} threads); {dev['cpu']}"
    )
    print("first = first call (trace + compile + run); run = median of repeats; cfg/s from the median\n")
    rows = []
    print(HEADER)
    print("-" * len(HEADER), flush=True)
    lwr_rate: dict[tuple[int, str], float] = {}
    for label, robot in robots:
        chain = None if args.no_torch else _torch_chain(robot)
        rng = np.random.default_rng(0)
        for dtype_name in dtypes:
            pk_chain = None
            if chain is not None:
                import torch

                pk_chain = chain.to(dtype=getattr(torch, dtype_name))
            for size in args.sizes:
                lo, hi = np.maximum(robot.lower, -np.pi), np.minimum(robot.upper, np.pi)
                q_np = rng.uniform(lo, hi, size=(size, robot.n))
                row = {"robot": label, **_measure_cell(robot, pk_chain, q_np, dtype_name, args)}
                if label == "kuka_lwr4":
                    lwr_rate[(size, dtype_name)] = row["jaxstiff_configs_per_s"]
                base = lwr_rate.get((size, dtype_name))
                row["vs_lwr"] = None if base is None else row["jaxstiff_configs_per_s"] / base
                rows.append(row)
                print(format_row(row), flush=True)
    if args.json:
        _write_json(
            args.json,
            {
                "benchmark": "fk_and_jacobian, " + ", ".join(label for label, _ in robots),
                "sizes": args.sizes,
                "dtypes": dtypes,
                "min_time_s": args.min_time,
                "device": dev,
                "versions": _versions(),
                "torch_threads": None if args.no_torch else (os.cpu_count() or 1),
                "rows": rows,
            },
        )
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
