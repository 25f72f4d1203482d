"""The parser on real LIGGGHTS output (tests/fixtures), and on damaged copies of it."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from pidpipe.errors import ParseError
from pidpipe.parsing import read_ave_time, read_cycles

FIXTURE = Path(__file__).parent / "fixtures" / "shake_1000Hz_10g"
PERIOD = 1.0 / 1000.0
CYCLES = 45


def _read(folder=FIXTURE, cycles=CYCLES):
    return read_cycles(folder / "power.txt", folder / "energy.txt", PERIOD, cycles)


def test_real_output_balance():
    series = _read()
    assert series.dissipated_j.shape == (CYCLES,)
    assert series.energy_j.shape == (CYCLES + 1,)
    # the balance telescopes: total dissipation = total wall work - net change of energy
    assert series.dissipated_j.sum() == pytest.approx(
        series.wall_work_j.sum() - (series.energy_j[-1] - series.energy_j[0]), rel=1e-12)
    measured = series.dissipated_j[5:]
    assert measured.mean() > 0
    # no cycle can dissipate more than the walls exchange with the spheres in it, beyond the
    # elastic energy held in contacts at a cycle boundary (a few per cent of a cycle's work)
    assert measured.mean() < series.gross_work_j[5:].mean() * 1.05
    assert np.all(series.lowest_z_m > -0.0127 - 2 * 2.5e-6)


def test_first_row_is_the_state_at_rest():
    energy = read_ave_time(FIXTURE / "energy.txt", 6)
    assert energy[0, 0] == 0 and energy[0, 1] == 0 and energy[0, 2] == 0


def _damaged(tmp_path, name, edit):
    folder = tmp_path / "damaged"
    shutil.copytree(FIXTURE, folder)
    path = folder / name
    path.write_text(edit(path.read_text()))
    return folder


def test_truncated_output(tmp_path):
    folder = _damaged(tmp_path, "power.txt", lambda t: "\n".join(t.splitlines()[:-3]) + "\n")
    with pytest.raises(ParseError, match="expected 45"):
        _read(folder)


def test_half_written_line(tmp_path):
    folder = _damaged(tmp_path, "energy.txt", lambda t: t.rstrip("\n")[:-12] + "\n")
    with pytest.raises(ParseError, match="fields, expected 6"):
        _read(folder)


def test_nan_energy(tmp_path):
    def poison(text):
        lines = text.splitlines()
        fields = lines[10].split()
        fields[1] = "nan"
        lines[10] = " ".join(fields)
        return "\n".join(lines) + "\n"

    folder = _damaged(tmp_path, "energy.txt", poison)
    with pytest.raises(ParseError, match="non-finite"):
        _read(folder)


def test_missing_file(tmp_path):
    with pytest.raises(ParseError, match="missing"):
        read_cycles(tmp_path / "power.txt", tmp_path / "energy.txt", PERIOD, CYCLES)
