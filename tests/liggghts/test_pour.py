"""A pour that has not settled after fidelity.settle_time_s goes on settling, with a cap.

Of 441 pours of the default config at 50 % fill (seeds fidelity.seed + 0 .. 440), replicates 97
and 438 had not settled after 0.15 s (fastest sphere 5.5 and 7.7 mm/s) and stopped the
campaign; one further chunk of the settle time settles both.
"""

import json
from pathlib import Path

import pytest

from pidpipe.cell.packing import SETTLED_SPEED_M_S, check_packing
from pidpipe.config.settings import PourSettings
from pidpipe.errors import PackingError
from pidpipe.liggghts.pour import MAX_FURTHER_SETTLING, pour
from tests.conftest import short_config

pytestmark = pytest.mark.engine

GOLDEN = Path(__file__).parent.parent / "golden"
UNSETTLED_REPLICATE = 97
"""Replicate whose 50 % pour had a sphere at 5.5 mm/s after the configured 0.15 s."""


def test_pour_not_settled_in_time_goes_on_settling_and_passes(tmp_path):
    packing = pour(PourSettings.from_config(short_config()), 50, UNSETTLED_REPLICATE, tmp_path)
    configured = json.loads((GOLDEN / "pack_r50pct_rep0.json").read_text())["settle_time_s"]
    # settled after one further chunk: twice the configured settle time (same timestep, steps)
    assert packing.settle_time_s == pytest.approx(2 * configured, rel=1e-12)
    assert packing.max_speed_m_s < 1e-4 < SETTLED_SPEED_M_S
    check_packing(packing, "f500Hz_G5_r50pct_rep97")
    # the same run went on: the pour's own deck with the further chunks appended
    deck = (tmp_path / "pour.lmp").read_text()
    assert deck.count("undump          settled") == MAX_FURTHER_SETTLING
    assert (tmp_path / "settled.dump").is_file()


def test_pour_settled_in_time_is_unchanged(half_fill_packing):
    """Replicate 0 settled within the configured time before: the same packing, bit for bit.

    tests/golden/pack_r50pct_rep0.json is that packing as poured before further settling existed.
    """
    before = json.loads((GOLDEN / "pack_r50pct_rep0.json").read_text())
    assert half_fill_packing.positions_m == before["positions_m"]
    assert half_fill_packing.max_speed_m_s == before["max_speed_m_s"]
    assert half_fill_packing.settle_time_s == before["settle_time_s"]


def test_pour_still_moving_after_the_cap_is_refused(tmp_path):
    cfg = short_config()
    cfg["fidelity"]["settle_time_s"] = 1e-4
    packing = pour(PourSettings.from_config(cfg), 50, 0, tmp_path)
    assert packing.max_speed_m_s > SETTLED_SPEED_M_S
    assert packing.settle_time_s == pytest.approx((1 + MAX_FURTHER_SETTLING) * 1e-4, rel=0.02)
    with pytest.raises(PackingError) as info:
        check_packing(packing, "f500Hz_G5_r50pct_rep0")
    message = str(info.value)
    assert "f500Hz_G5_r50pct_rep0" in message and "had not settled" in message
    assert f"up to {MAX_FURTHER_SETTLING} more" in message and "fidelity.settle_time_s" in message
