"""Benchmark: FK + geometric Jacobian of the 7-DOF KUKA LWR 4, jaxstiff vs pytorch-kinematics.

Both libraries run side by side in one process on the same joint values (uniform inside the
joint limits), for each batch size and dtype:

* jaxstiff: ``jaxstiff.fk_and_jacobian(robot, q)`` (one jit-compiled pass, the pose (B, 4, 4) and
  J (B, 6, 7)) on JAX's default device.
* pytorch-kinematics: ``chain.jacobian(th, ret_eef_pose=True)`` (its fastest public call that
  returns both), on the CPU with ``torch.set_num_threads(<all cores>)``, chain moved to the dtype.

Compilation is timed apart from running: "first" is the first call (tracing + compilation + one
run; for pytorch-kinematics its warm-up call), "run" the median (and best) of repeated calls,
each ended with ``block_until_ready`` (JAX) - torch on the CPU is synchronous. Throughput is
configurations per second from the median; "ratio" is jaxstiff / pytorch-kinematics. Each row
also records the largest difference between the two results (pytorch-kinematics parses URDF
numbers in float32, so ~1e-7 is agreement).

Usage:
    python scripts/bench_kinematics.py                          # sizes 1, 1e3, 1e5, 1e6; float32 and float64
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

DEFAULT_SIZES = (1, 1_000, 100_000, 1_000_000)


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


def bench_jaxstiff(robot, q_np, dtype_name, min_time, max_repeats):
    import jax
    import jax.numpy as jnp

    import jaxstiff

    q = jax.block_until_ready(jnp.asarray(q_np, dtype=getattr(jnp, dtype_name)))

    def call():
        return jax.block_until_ready(jaxstiff.fk_and_jacobian(robot, q))

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
    f"{'batch':>9} {'dtype':>7} | {'jx first':>9} {'jx run':>9} {'jx cfg/s':>9} | "
    f"{'pk first':>9} {'pk run':>9} {'pk cfg/s':>9} | {'ratio':>7} {'max|diff|':>9}"
)


def format_row(r: dict) -> str:
    ratio = "-" if r["ratio"] is None else f"{r['ratio']:.1f}x"
    diff = "-" if r["max_abs_diff"] is None else f"{r['max_abs_diff']:.1e}"
    return (
        f"{r['batch']:>9} {r['dtype']:>7} | {_fmt_s(r['jaxstiff_first_s']):>9} "
        f"{_fmt_s(r['jaxstiff_run_median_s']):>9} {_fmt_rate(r['jaxstiff_configs_per_s']):>9} | "
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
    ap.add_argument("--sizes", type=_sizes, default=list(DEFAULT_SIZES), help="comma-separated batch sizes")
    ap.add_argument("--dtypes", default="float32,float64", help="comma-separated: float32, float64")
    ap.add_argument("--min-time", type=float, default=1.0, help="seconds of timed calls per cell (at least 3 calls)")
    ap.add_argument("--max-repeats", type=int, default=2000, help="upper bound on timed calls per cell")
    ap.add_argument("--no-torch", action="store_true", help="skip pytorch-kinematics")
    ap.add_argument("--json", default=None, metavar="FILE", help="write rows, device, versions and sizes here")
    args = ap.parse_args(argv)
    dtypes = [d.strip() for d in args.dtypes.split(",") if d.strip()]
    if not dtypes or any(d not in ("float32", "float64") for d in dtypes):
        ap.error(f"--dtypes: choose from float32, float64, got {args.dtypes!r}")
    return args, dtypes


def _torch_chain(robot_file: str):
    """pytorch-kinematics' serial chain of the LWR (torch on all cores), or None if it is not installed."""
    try:
        import pytorch_kinematics as pk
        import torch
    except ImportError:
        print("pytorch-kinematics/torch not installed: jaxstiff only (pip install '.[ref]')", file=sys.stderr)
        return None
    torch.set_num_threads(os.cpu_count() or 1)
    with open(robot_file) as fh:
        return pk.build_serial_chain_from_urdf(fh.read(), "lwr_flange", "lwr_base")


def _measure_cell(robot, pk_chain, q_np, dtype_name: str, args: argparse.Namespace) -> dict:
    """One row: jaxstiff (and pytorch-kinematics if ``pk_chain``) at one batch size and dtype."""
    import numpy as np

    size = q_np.shape[0]
    first, times, (T, J) = bench_jaxstiff(robot, q_np, dtype_name, args.min_time, args.max_repeats)
    med = statistics.median(times)
    row = {
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

    from jaxstiff.runtime.x64 import enable_x64

    enable_x64()  # float64 available; float32 inputs stay float32 (the kernel keeps the dtype)
    import numpy as np

    import jaxstiff

    robot = jaxstiff.Robot.from_urdf("kuka_lwr4")
    chain = None if args.no_torch else _torch_chain(jaxstiff.robot_path("kuka_lwr4"))

    dev = _device()
    print(
        f"FK + Jacobian, KUKA LWR 4 (7 DOF); jaxstiff on {dev['jax_backend']} ({dev['jax_device']}), "
        f"pytorch-kinematics on CPU ({os.cpu_count()} threads); {dev['cpu']}"
    )
    print("first = first call (trace + compile + run); run = median of repeats; cfg/s from the median\n")
    rng = np.random.default_rng(0)
    rows = []
    print(HEADER)
    print("-" * len(HEADER), flush=True)
    for dtype_name in dtypes:
        pk_chain = None
        if chain is not None:
            import torch

            pk_chain = chain.to(dtype=getattr(torch, dtype_name))
        for size in args.sizes:
            q_np = rng.uniform(robot.lower, robot.upper, size=(size, robot.n))
            row = _measure_cell(robot, pk_chain, q_np, dtype_name, args)
            rows.append(row)
            print(format_row(row), flush=True)
    if args.json:
        _write_json(
            args.json,
            {
                "benchmark": "fk_and_jacobian, KUKA LWR 4",
                "sizes": args.sizes,
                "dtypes": dtypes,
                "min_time_s": args.min_time,
                "device": dev,
                "versions": _versions(),
                "torch_threads": (os.cpu_count() or 1) if chain is not None else None,
                "rows": rows,
            },
        )
        print(f"\nwrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
