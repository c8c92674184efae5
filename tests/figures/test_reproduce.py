"""``jaxstiff reproduce`` on a folder of fake experiment scripts (fast: none imports JAX): discovery
and order, --quick only where supported, figures and tables gathered into one report, a failing and
a hanging experiment reported without stopping the others, clear errors without a checkout."""

from __future__ import annotations

import base64
import os
import textwrap

import pytest

from jaxstiff.cli import main
from jaxstiff.cli._reproduce import load_runner

reproduce = load_runner()  # the runner lives in the checkout's experiments/_reproduce

# a valid 1x1 PNG, written by the fake experiments
PNG = base64.b64decode(
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNk+M9QDwADhgGAWjR9awAAAABJRU5ErkJggg=="
)


def _script(body: str) -> str:
    return (
        textwrap.dedent("""\
        import argparse, base64, os, sys
        ap = argparse.ArgumentParser()
        ap.add_argument("--out", required=True)
        ap.add_argument("--quick", action="store_true")
        a = ap.parse_args()
        os.makedirs(a.out, exist_ok=True)
        PNG = base64.b64decode({png!r})
        """).format(png=base64.b64encode(PNG).decode())
        + textwrap.dedent(body)
        + '\nif __name__ == "__main__":\n    pass\n'
    )


@pytest.fixture()
def fake_experiments(tmp_path):
    d = tmp_path / "experiments"
    d.mkdir()
    (d / "fig2_cms.py").write_text(
        _script("""
        open(os.path.join(a.out, "ellipses.png"), "wb").write(PNG)
        open(os.path.join(a.out, "extra.png"), "wb").write(PNG)
        open(os.path.join(a.out, "summary.md"), "w").write("# Fig. 2\\n\\nscaled ellipses ![e](ellipses.png)\\n")
        """).replace("--quick", "--fast")
    )
    (d / "csc_hold.py").write_text(
        _script("""
        open(os.path.join(a.out, "quick.txt"), "w").write(str(a.quick))
        open(os.path.join(a.out, "table.csv"), "w").write("beta,u_end\\n0.001,2030.5\\n0.002,1500.25\\n")
        open(os.path.join(a.out, "u.png"), "wb").write(PNG)
        open(os.path.join(a.out, "summary.json"), "w").write('{"u_start": 5994.9335, "setup": {"q0_deg": [75.0, -74.74, -76.3]}}')
        print("u: 5994.9 -> 2003.1 Nm/rad")
        """)
    )
    (d / "fig9_broken.py").write_text(
        _script("""
        print("computing ...")
        sys.exit("fig9: the solver diverged at waypoint 7")
        """)
    )
    (d / "fig3_hangs.py").write_text(
        _script("""
        import time
        time.sleep(60)
        """)
    )
    (d / "common.py").write_text("def helper():\n    return 1\n")  # no __main__: not an experiment
    (d / "_private.py").write_text(_script(""))
    return d


def test_discovery_order(fake_experiments):
    (fake_experiments / "study_long.py").write_text(_script(""))
    names = [os.path.basename(p) for p in reproduce.discover(str(fake_experiments))]
    assert names == ["fig2_cms.py", "fig3_hangs.py", "csc_hold.py", "fig9_broken.py", "study_long.py"]
    seeds = [os.path.basename(p) for p in reproduce.discover(str(fake_experiments), everything=False)]
    assert seeds == ["fig2_cms.py", "fig3_hangs.py", "csc_hold.py"]


@pytest.mark.slow
def test_report_gathers_everything_and_survives_failures(fake_experiments, tmp_path):
    out = tmp_path / "report"
    res = reproduce.run_reproduce(
        out, quick=True, experiments_dir=fake_experiments, timeout=3.0, sweep=False, everything=True, log=lambda s: None
    )
    status = {r.name: r.code for r in res.runs}
    assert status == {"fig2_cms": 0, "fig3_hangs": None, "csc_hold": 0, "fig9_broken": 1}
    assert not res.ok
    md = (out / "report.md").read_text()
    # sections in discovery order
    pos = [md.index(f"## {n}") for n in ("fig2_cms", "fig3_hangs", "csc_hold", "fig9_broken")]
    assert pos == sorted(pos)
    # figures copied next to the report, the experiment's own link rewritten, unlinked ones appended
    assert (out / "figures" / "fig2_cms" / "ellipses.png").read_bytes() == PNG
    assert "![e](figures/fig2_cms/ellipses.png)" in md
    assert "](figures/fig2_cms/extra.png)" in md and "](figures/csc_hold/u.png)" in md
    assert "### Fig. 2" in md  # the experiment's top heading goes right below its section
    # CSV as a Markdown table
    assert "| beta | u_end |" in md and "| 0.001 | 2030 |" in md.replace("2031", "2030")
    # what it printed, and its JSON summary as a key/value table
    assert "u: 5994.9 -> 2003.1 Nm/rad" in md
    assert "| u_start | 5994.93 |" in md and "| setup.q0_deg | [75, -74.74, -76.3] |" in md
    # --quick only where the script has it
    assert (out / "runs" / "csc_hold" / "quick.txt").read_text() == "True"
    assert "--quick" not in (out / "runs" / "fig2_cms" / "log.txt").read_text().splitlines()[0]
    assert (
        "`python experiments/fig2_cms.py --out DIR`" in md
        and "`python experiments/csc_hold.py --out DIR --quick`" in md
    )
    # failures: exit code and the end of the log; the hang: timed out
    assert "failed with exit code 1" in md and "the solver diverged at waypoint 7" in md
    assert "timed out" in md
    # the report can be rebuilt from the runs without running anything again
    (out / "report.md").unlink()
    again = reproduce.run_reproduce(
        out, experiments_dir=fake_experiments, sweep=False, everything=True, report_only=True, log=lambda s: None
    )
    assert [r.name for r in again.runs] == [r.name for r in res.runs]
    assert (out / "report.md").read_text().split("- total wall time")[1] == md.split("- total wall time")[1].replace(
        f"{res.wall_s:.0f} s", f"{sum(r.wall_s for r in res.runs):.0f} s", 1
    )


def test_cli_only_and_errors(fake_experiments, tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["reproduce", "--out", str(out), "--experiments", str(fake_experiments), "--only", "csc"]) == 0
    assert "1 of 1 ok" in capsys.readouterr().out
    md = (out / "report.md").read_text()
    assert "## csc_hold" in md and "## fig2_cms" not in md
    assert main(["reproduce", "--out", str(out), "--experiments", str(fake_experiments), "--only", "fig7"]) == 2
    assert "--only fig7: no experiment matches" in capsys.readouterr().err
    assert main(["reproduce", "--out", str(out), "--experiments", str(tmp_path / "nope")]) == 2
    assert "not a folder with experiment scripts" in capsys.readouterr().err
    a_file = tmp_path / "report.txt"
    a_file.write_text("x")
    assert main(["reproduce", "--out", str(a_file), "--experiments", str(fake_experiments), "--only", "csc"]) == 2
    assert "--out: " in capsys.readouterr().err and a_file.read_text() == "x"  # was a raw "[Errno 20] Not a directory"
    # --report-only on a folder without runs: refused, and no empty DIR/runs is left behind
    missing = tmp_path / "never_run"
    assert main(["reproduce", "--out", str(missing), "--experiments", str(fake_experiments), "--report-only"]) == 2
    assert "--report-only: no runs in" in capsys.readouterr().err and not missing.exists()


def test_without_a_source_checkout_the_message_says_what_to_do(tmp_path, monkeypatch):
    from jaxstiff.cli import _reproduce as cli_reproduce

    monkeypatch.setattr(reproduce, "__file__", str(tmp_path / "site-packages" / "experiments" / "_reproduce" / "r.py"))
    monkeypatch.delenv("JAXSTIFF_EXPERIMENTS", raising=False)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(FileNotFoundError) as info:
        reproduce.find_experiments_dir()
    msg = str(info.value)
    assert "experiments/ folder of a source checkout" in msg and "--experiments DIR" in msg
    assert str(tmp_path / "site-packages" / "experiments") in msg
    # an installed package without a checkout: the command cannot find its runner, and says so
    monkeypatch.setattr(cli_reproduce, "_CHECKOUT", str(tmp_path / "site-packages"))
    with pytest.raises(FileNotFoundError, match="JAXSTIFF_EXPERIMENTS"):
        cli_reproduce.load_runner()


def test_environment_variable_is_used(fake_experiments, tmp_path, monkeypatch):
    monkeypatch.setattr(reproduce, "__file__", str(tmp_path / "elsewhere" / "experiments" / "_reproduce" / "r.py"))
    monkeypatch.setenv("JAXSTIFF_EXPERIMENTS", str(fake_experiments))
    assert reproduce.find_experiments_dir() == str(fake_experiments)
