"""The scene study's config section, its Snakemake target (planned, not run) and its figure."""

import csv
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import pytest

from pidpipe.config import load_config, validate_config
from pidpipe.errors import ConfigError
from pidpipe.studies.scene import SCENE_LABELS, plot_table, read_scene_table

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE = Path(sys.executable).with_name("snakemake")


def test_scene_defaults_and_a_bad_value_named():
    scene = load_config()["scene"]
    assert scene["coupon_columns"] * scene["coupon_rows"] == 441 and scene["singles"] >= 19
    raw = load_config()
    raw["scene"]["singles"] = 3
    with pytest.raises(ConfigError, match="scene.singles"):
        validate_config(raw)


@pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake is not in the virtual environment")
def test_scene_target_plans_the_study_and_its_figure(tmp_path):
    shutil.copy(ROOT / "config.yaml", tmp_path / "config.yaml")
    run = subprocess.run([str(SNAKEMAKE), "--snakefile", str(ROOT / "Snakefile"), "--directory",
                          str(tmp_path), "--cores", "2", "--dry-run", "scene"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    for rule in ("run_scene_study", "plot_scene", "scene"):
        assert f"rule {rule}:" in run.stdout
    assert "simulate_case" not in run.stdout        # the scene needs no campaign job


def test_figure_from_a_scene_table(tmp_path):
    path = tmp_path / "scene.csv"
    fields = ["freq_hz", "accel_g", "scene", "label", "cells", "ceq_cell_ns_m", "sem_cycles_ns_m",
              "sem_cells_ns_m", "ceq_coupon_ns_m", "sem_coupon_ns_m", "cpu_s",
              "cpu_ms_per_cell_cycle", "cpu_ratio_to_one_cell", "measured_cycles"]
    cells = {"single": 1, "replicates7": 7, "replicates19": 19, "patch7": 7, "patch19": 19, "coupon": 441}
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(fields)
        for name, n in cells.items():
            writer.writerow([500, 5, name, SCENE_LABELS[name], n, 0.12 + 0.001 * n ** 0.5, 0.004,
                             "nan" if n == 1 else 0.002, 441 * 0.12, 1.0, 2.0 * n, 30.0, n, 40])
    rows = read_scene_table(path)
    assert rows[0]["cells"] == 1 and rows[-1]["cpu_s"] == 882.0
    png = plot_table(path, tmp_path / "scene.png")
    image = matplotlib.image.imread(png)
    assert image.shape[0] > 300 and image[..., :3].std() > 0.1
