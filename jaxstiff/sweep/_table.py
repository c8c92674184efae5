"""The assembled results table of a sweep: column dtypes, the CSV fallback, and reading it back."""

from __future__ import annotations

import os
from collections.abc import Iterable
from typing import Any

from jaxstiff.sweep._axes import AXES

__all__ = ["read_table"]


def table_frame(rows: list[dict], cols: list[str], kind: str) -> Any:
    """The results table as a pandas DataFrame with fixed column order and dtypes."""
    import pandas as pd

    df = pd.DataFrame.from_records(rows, columns=cols)
    for name, spec in AXES[kind].items():
        if spec.type == "float":
            df[name] = df[name].astype("float64")
        elif spec.type == "int":
            df[name] = df[name].astype("int64")
        elif spec.type == "bool":
            df[name] = df[name].astype(bool)
        else:
            df[name] = df[name].astype(str)
    for c in ("row_id", "chunk", "group", "path_index", "P", "result_index"):
        df[c] = df[c].astype("int64")
    df["q0_ik_error_m"] = df["q0_ik_error_m"].astype("float64")  # (NaN where the start posture is no IK solution)
    return df


def rows_csv(rows: Iterable[dict], cols: list[str]) -> str:
    """The table as CSV text (floats as ``repr``, so they read back exactly)."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([repr(r[c]) if isinstance(r[c], float) else r[c] for c in cols])
    return buf.getvalue()


def read_table(out: str | os.PathLike) -> Any:
    """The results table of a finished sweep folder as a pandas DataFrame (Parquet, else CSV)."""
    import pandas as pd

    out = os.fspath(out)
    pq = os.path.join(out, "results.parquet")
    if os.path.isfile(pq):
        return pd.read_parquet(pq)
    csvf = os.path.join(out, "results.csv")
    if os.path.isfile(csvf):
        return pd.read_csv(csvf)
    raise FileNotFoundError(f"no results table in {out} (the sweep has not finished; run it again with --resume)")
