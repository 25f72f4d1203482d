"""One case end to end with the real LIGGGHTS."""

import json
import math

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import check_packing
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.errors import EngineError, PackingError
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.process import run_deck
from pidpipe.liggghts.shake import run_case
from tests.conftest import short_config

pytestmark = pytest.mark.engine


def test_ceq_is_finite_positive_and_reproducible(tmp_path, half_fill_packing):
    cfg = short_config(transient=3, measured=12)
    case = CaseSpec(500, 5, 50)
    first = run_case(ShakeSettings.from_config(cfg), case, half_fill_packing, tmp_path / "a")
    second = run_case(ShakeSettings.from_config(cfg), case, half_fill_packing, tmp_path / "b")
    assert math.isfinite(first.ceq_cell_ns_m) and first.ceq_cell_ns_m > 0
    assert first.ceq_cell_sem_ns_m > 0
    assert first.ceq_coupon_ns_m == pytest.approx(441 * first.ceq_cell_ns_m)
    assert second.ceq_cell_ns_m == first.ceq_cell_ns_m
    assert second.cycles == first.cycles
    fidelity = first.fidelity
    assert fidelity["rayleigh_fraction"] <= 0.2 and fidelity["steps_per_cycle"] * fidelity["timestep_s"] == pytest.approx(1 / 500)
    assert "3.8" in first.engine["liggghts_version"]
    path = first.write(tmp_path / "record.json")
    assert json.loads(path.read_text())["case_id"] == "f500Hz_G5_r50pct_rep0"


def test_same_seed_same_packing(tmp_path, half_fill_packing):
    again = pour(PourSettings.from_config(short_config()), 50, 0, tmp_path)
    assert again.positions_m == half_fill_packing.positions_m
    other = pour(PourSettings.from_config(short_config()), 50, 1, tmp_path)
    assert other.positions_m != half_fill_packing.positions_m


def test_overfull_cell_is_refused_before_shaking(tmp_path):
    cfg = short_config()
    cfg["fill"]["definition"] = "source_36"
    packing = pour(PourSettings.from_config(cfg), 90, 0, tmp_path)
    assert packing.n_spheres == 32 and not packing.fits
    with pytest.raises(PackingError) as info:
        check_packing(packing, "f500Hz_G5_r90pct_rep0")
    message = str(info.value)
    assert "f500Hz_G5_r90pct_rep0" in message and "32 spheres" in message and "25.4 mm" in message
    with pytest.raises(PackingError):
        run_case(ShakeSettings.from_config(cfg), CaseSpec(500, 5, 90), packing, tmp_path / "shake")
    assert not (tmp_path / "shake" / "shake.lmp").exists()


def test_failed_run_names_case_and_screen(tmp_path):
    deck = tmp_path / "broken.lmp"
    deck.write_text("units si\natom_style granular\nnot_a_command 1 2 3\n")
    with pytest.raises(EngineError) as info:
        run_deck(deck, "f1Hz_G1_r1pct_rep0")
    assert "f1Hz_G1_r1pct_rep0" in str(info.value) and "screen.txt" in str(info.value)
    assert "ERROR" in str(info.value)


def test_missing_binary_says_how_to_install(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("PIDPIPE_LIGGGHTS", raising=False)
    deck = tmp_path / "x.lmp"
    deck.write_text("units si\n")
    with pytest.raises(EngineError, match="apt-get install -y --no-install-recommends liggghts"):
        run_deck(deck, "case")


def test_a_longer_window_repeats_the_shorter_one_cycle_for_cycle(tmp_path, half_fill_packing):
    # pidpipe.measurement.adaptive extends a case by running it again with more cycles: that only adds
    # cycles if the same seed and packing replay the same trajectory.
    case = CaseSpec(1000.0, 10.0, 50.0)
    short = run_case(ShakeSettings.from_config(short_config(transient=3, measured=4)), case, half_fill_packing, tmp_path / "short")
    long = run_case(ShakeSettings.from_config(short_config(transient=3, measured=8)), case, half_fill_packing, tmp_path / "long")
    n = len(short.cycles["dissipated_j"])
    assert long.cycles["dissipated_j"][:n] == short.cycles["dissipated_j"]
    assert len(long.cycles["dissipated_j"]) == n + 4
