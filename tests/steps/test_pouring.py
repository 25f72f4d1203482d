"""Which engine pours (``fidelity.pour_engine``), and a packing of the other engine is poured
again, not reused: the pool of a case's further packings and the studies' replicate packings."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from pidpipe.cell.packing import load_packing, reusable
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings
from pidpipe.dem.pouring import pour_with_engine, replicate_packings
from pidpipe.steps.cases import pool_packings
from pidpipe.steps.packings import pour_packing

GOLDEN = Path(__file__).parent.parent / "golden"


def _settings(engine: str) -> PourSettings:
    settings = PourSettings.from_config(load_config())
    return dataclasses.replace(settings, pouring=dataclasses.replace(settings.pouring, engine=engine))


def test_a_packing_file_from_before_the_dem_poured_reads_as_poured_by_liggghts():
    packing = load_packing(GOLDEN / "pack_r50pct_rep0.json")
    assert packing.pour_engine == "liggghts"
    assert reusable(packing, packing.seed, packing.n_spheres, "liggghts")
    assert not reusable(packing, packing.seed, packing.n_spheres, "dem")
    assert not reusable(packing, packing.seed + 1, packing.n_spheres, "liggghts")
    assert not reusable(packing, packing.seed, packing.n_spheres + 1, "liggghts")


def test_the_pour_step_pours_with_the_configured_engine(tmp_path):
    config = load_config()
    config["fidelity"]["pour_engine"] = "dem"
    pour_packing(config, 25, 0, str(tmp_path / "r25pct_rep0.json"), str(tmp_path / "work"))
    packing = load_packing(tmp_path / "r25pct_rep0.json")
    assert packing.pour_engine == "dem" and packing.n_spheres == 5
    assert packing == pour_with_engine(_settings("dem"), 25, 0, tmp_path)


@pytest.mark.engine
def test_a_pool_packing_of_the_other_engine_is_poured_again_and_one_of_the_same_is_reused(tmp_path):
    folder, index = tmp_path / "pool", 10000
    path = folder / f"r25pct_rep{index}.json"
    [liggghts] = pool_packings(_settings("liggghts"), 25, [index], folder)
    assert liggghts.pour_engine == "liggghts" and load_packing(path) == liggghts
    [dem] = pool_packings(_settings("dem"), 25, [index], folder)
    assert dem.pour_engine == "dem" and load_packing(path) == dem
    assert dem.seed == liggghts.seed and dem.positions_m != liggghts.positions_m
    written = path.stat().st_mtime_ns
    [again] = pool_packings(_settings("dem"), 25, [index], folder)
    assert again == dem and path.stat().st_mtime_ns == written


@pytest.mark.engine
def test_replicate_packings_pour_again_when_the_engine_changes(tmp_path):
    folder = tmp_path / "packings"
    [dem], dem_cpu = replicate_packings(_settings("dem"), 25, 1, folder)
    assert dem.pour_engine == "dem" and dem_cpu[0] > 0
    [liggghts], liggghts_cpu = replicate_packings(_settings("liggghts"), 25, 1, folder)
    assert liggghts.pour_engine == "liggghts" and liggghts.seed == dem.seed
    assert load_packing(folder / "r25pct_rep0.json") == liggghts
    assert liggghts_cpu[0] > 0 and liggghts_cpu[0] != dem_cpu[0]


def test_pool_pours_its_missing_packings_together_and_waits_for_one_another_case_holds(tmp_path, caplog):
    """The pool's missing packings are poured in one call, each the packing the DEM pours
    alone; one whose lock another case holds is waited for, then read, not poured again."""
    import fcntl
    import threading

    from pidpipe.dem.pour import pour

    settings, folder = _settings("dem"), tmp_path / "pool"
    [kept] = pool_packings(settings, 25, [10001], folder)
    kept_path = folder / "r25pct_rep10001.json"
    written = kept_path.stat().st_mtime_ns
    locked, released = threading.Event(), threading.Event()

    def other_case():                   # holds packing 10001's lock, as a concurrent case would
        with open(folder / ".r25pct_rep10001.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            locked.set()
            threading.Event().wait(0.5)
            released.set()

    holder = threading.Thread(target=other_case)
    holder.start()
    locked.wait()
    caplog.set_level("INFO", logger="pidpipe.campaign")
    caplog.clear()      # only this call's pours count (an earlier test may have left INFO on)
    packings = pool_packings(settings, 25, [10002, 10001, 10000], folder)
    assert released.is_set()            # it could only read 10001 after the other case let go
    holder.join()
    assert packings == [pour(settings, 25, 10002), kept, pour(settings, 25, 10000)]
    assert kept_path.stat().st_mtime_ns == written
    poured = [r.getMessage().split()[2] for r in caplog.records if r.getMessage().startswith("poured packing")]
    assert poured == ["r25pct_rep10002", "r25pct_rep10000"]
    for index, packing in ((10002, packings[0]), (10000, packings[2])):
        assert load_packing(folder / f"r25pct_rep{index}.json") == packing
