"""`pidpipe optimise`: the optimisation stage alone, on any C_eq table with the four columns."""

import itertools
import subprocess
import sys

import numpy as np
import pandas as pd
import yaml

from pidpipe.cli import EXIT_USER_ERROR, main
from pidpipe.config import DEFAULT_CONFIG_PATH


def write_table(path, sem=True):
    """C_eq = f G r exp(-r/30) / 1000 on the reference grid: C/r falls with r, so the designs
    fill as many cells as allowed at the lowest fill."""
    rows = pd.DataFrame(list(itertools.product((50.0, 100.0, 500.0, 750.0, 1000.0), (1.0, 5.0, 10.0),
                                               (25.0, 50.0, 75.0, 90.0))),
                        columns=["freq_hz", "accel_g", "fill_pct"])
    rows["ceq_coupon_ns_m"] = rows.freq_hz * rows.accel_g * rows.fill_pct * np.exp(-rows.fill_pct / 30) / 1000
    if sem:
        rows["ceq_coupon_sem_ns_m"] = 0.03 * rows["ceq_coupon_ns_m"]
    rows.to_csv(path, index=False)
    return path


def write_config(path, **sections):
    """config.yaml with the given sections merged in (dicts) or replaced (lists)."""
    config = yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())
    for key, value in sections.items():
        config[key] = {**config[key], **value} if isinstance(value, dict) else value
    path.write_text(yaml.safe_dump(config))
    return path


def test_designs_of_an_external_table_are_printed_for_a_panel_larger_than_the_coupon(tmp_path, capsys):
    table = write_table(tmp_path / "published.csv")
    config = write_config(tmp_path / "config.yaml", panel={"n_cells": 1764},
                          fill={"definition": "source_36"}, grid={"fill_pct": [25, 50]},
                          budget={"mode": "spheres", "spheres": 15876},
                          environments=[{"name": "250-300 Hz, 5-6 g", "freq_hz": [250, 300], "accel_g": [5, 6]},
                                        {"name": "450-500 Hz, 1-2 g", "freq_hz": [450, 500], "accel_g": [1, 2]}],
                          optimisation={"starts": 6, "bootstrap": {"draws": 8}})
    out = tmp_path / "designs.csv"
    assert main(["optimise", "--table", str(table), "--config", str(config), "--output", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "15876 spheres, at most 1764 cells" in printed
    for kind in ("peak", "band_mean", "worst_case"):
        assert kind in printed
    assert printed.count("warning: band reaches G <= 1") == 1
    assert "95 % bootstrap interval of 8 draws" in printed
    designs = pd.read_csv(out)
    assert len(designs) == 6 and (designs["n_cells"] == 1764).all()  # 9 spheres (25 %) in each cell
    assert np.allclose(designs["fill_pct"], 25.0) and (designs["bootstrap_used"] == 8).all()
    assert out.with_suffix(".json").stat().st_size > 0


def test_a_table_without_sems_gets_designs_and_says_why_it_has_no_intervals(tmp_path, capsys):
    """An interpolant fits a table without SEMs (designs, no intervals); the default GP, which
    fits each case with its SEM, refuses it in one line that names the way out."""
    table = write_table(tmp_path / "no_sem.csv", sem=False)
    config = write_config(tmp_path / "config.yaml", optimisation={"starts": 4},
                          environments=[{"name": "e", "freq_hz": [250, 300], "accel_g": [5, 6]}])
    assert main(["optimise", "--table", str(table), "--config", str(config)]) == EXIT_USER_ERROR
    refused = capsys.readouterr().err
    assert "has no column ceq_coupon_sem_ns_m" in refused and "rbf_thin_plate" in refused
    write_config(tmp_path / "config.yaml", optimisation={"starts": 4}, surrogate={"method": "rbf_thin_plate"},
                 environments=[{"name": "e", "freq_hz": [250, 300], "accel_g": [5, 6]}])
    assert main(["optimise", "--table", str(table), "--config", str(config)]) == 0
    printed = capsys.readouterr().out
    assert "note: the table has no ceq_coupon_sem_ns_m" in printed and "[" not in printed.split("\n")[2]


def test_a_bad_table_gets_one_clear_line(tmp_path):
    rows = pd.read_csv(write_table(tmp_path / "t.csv")).drop(columns="ceq_coupon_ns_m")
    rows.to_csv(tmp_path / "bad.csv", index=False)
    write_config(tmp_path / "config.yaml")
    run = subprocess.run([sys.executable, "-m", "pidpipe.cli", "optimise", "--table", str(tmp_path / "bad.csv")],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == EXIT_USER_ERROR
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr
    assert lines[0].startswith("pidpipe: error: C_eq table") and "missing required column(s) ceq_coupon_ns_m" in lines[0]
