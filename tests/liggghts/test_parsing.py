"""The parser on real LIGGGHTS output (tests/fixtures), and on damaged copies of it."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.errors import ParseError
from pidpipe.liggghts.contact_energy import boundary_elastic_energy
from pidpipe.liggghts.parsing import (
    CONTACT_COLUMNS,
    read_ave_time,
    read_cycles,
    read_local_frames,
)

FIXTURE = Path(__file__).parents[1] / "fixtures" / "shake_1000Hz_10g"
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


def _damaged(tmp_path, name, edit, source=FIXTURE):
    """A copy of a fixture folder with one file edited."""
    folder = tmp_path / "damaged"
    shutil.copytree(source, folder)
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


# The contact dumps of a real run (tests/fixtures/README.md): 500 Hz, 5 g, 11 spheres, 6 cycles.
CONTACTS = Path(__file__).parents[1] / "fixtures" / "shake_500Hz_5g_contacts"
CONTACT_CYCLES = 6
CONTACT_SPHERES = 11
STEPS_PER_CYCLE = 2223
BOUNDARIES = STEPS_PER_CYCLE * np.arange(CONTACT_CYCLES + 1)


def test_real_contact_dumps():
    for name, ids in (("pair_contacts.dump", slice(0, 2)), ("wall_contacts.dump", slice(2, 3))):
        steps, frames = read_local_frames(CONTACTS / name, len(CONTACT_COLUMNS))
        assert np.array_equal(steps, BOUNDARIES)
        atoms = np.concatenate([frame[:, ids] for frame in frames])
        assert np.all(atoms == np.round(atoms)) and atoms.min() >= 1 and atoms.max() <= 11
        overlap = np.concatenate([frame[:, CONTACT_COLUMNS.index("overlap")] for frame in frames])
        assert overlap.max() < 1e-5       # nanometres to micrometres, never a sizeable part of a radius
        # the poured packing starts with no tangential spring stretched; shaking stretches some
        shear = slice(CONTACT_COLUMNS.index("shear_x"), CONTACT_COLUMNS.index("shear_z") + 1)
        assert np.all(frames[0][:, shear] == 0) and any(np.any(f[:, shear] != 0) for f in frames[1:])
    steps, frames = read_local_frames(CONTACTS / "wall_contacts.dump", len(CONTACT_COLUMNS))
    assert [len(frame) for frame in frames] == [17, 14, 1, 10, 11, 1, 9]


def _contact_balance(folder=CONTACTS):
    elastic = boundary_elastic_energy(folder / "pair_contacts.dump", folder / "wall_contacts.dump",
                                      CellScene.from_config(load_config()), BOUNDARIES, np.zeros(CONTACT_SPHERES, dtype=int))[:, 0]
    return read_cycles(folder / "power.txt", folder / "energy.txt", 1.0 / 500.0, CONTACT_CYCLES,
                       elastic_j=elastic)


def test_balance_counts_the_elastic_energy_at_every_boundary():
    series = _contact_balance()
    assert np.all(series.elastic_j > 0)
    assert np.allclose(series.energy_j, series.mechanical_j + series.elastic_j, rtol=0, atol=1e-20)
    assert np.allclose(series.dissipated_j, series.wall_work_j - np.diff(series.energy_j),
                       rtol=0, atol=1e-20)
    # without it every cycle is off by the change of the elastic energy across it
    plain = read_cycles(CONTACTS / "power.txt", CONTACTS / "energy.txt", 1.0 / 500.0, CONTACT_CYCLES)
    assert np.all(np.isnan(plain.elastic_j))
    assert np.allclose(plain.dissipated_j - series.dissipated_j, np.diff(series.elastic_j),
                       rtol=0, atol=1e-20)
    record = series.as_record()
    assert len(record["elastic_j"]) == len(record["mechanical_j"]) == CONTACT_CYCLES + 1


def _damaged_contacts(tmp_path, edit, name="wall_contacts.dump"):
    return _damaged(tmp_path, name, edit, source=CONTACTS)


def test_truncated_contact_dump(tmp_path):
    # the run died while writing the last frame
    folder = _damaged_contacts(tmp_path, lambda t: "\n".join(t.splitlines()[:-4]) + "\n")
    with pytest.raises(ParseError, match="does not hold 9 rows"):
        _contact_balance(folder)


def test_contact_dump_that_stops_at_a_frame_boundary(tmp_path):
    def drop_last_frame(text):
        lines = text.splitlines()
        last = max(i for i, line in enumerate(lines) if line.startswith("ITEM: TIMESTEP"))
        return "\n".join(lines[:last]) + "\n"

    folder = _damaged_contacts(tmp_path, drop_last_frame, "pair_contacts.dump")
    with pytest.raises(ParseError, match="expected the 7 cycle boundaries"):
        _contact_balance(folder)


def test_contact_dump_with_a_short_row(tmp_path):
    def cut(text):
        lines = text.splitlines()
        lines[9] = " ".join(lines[9].split()[:-1])
        return "\n".join(lines) + "\n"

    with pytest.raises(ParseError, match="of 7 columns"):
        _contact_balance(_damaged_contacts(tmp_path, cut))


def test_contact_dump_with_nan_and_garbage(tmp_path):
    def poison(value):
        def edit(text):
            lines = text.splitlines()
            fields = lines[9].split()
            fields[-1] = value
            lines[9] = " ".join(fields)
            return "\n".join(lines) + "\n"
        return edit

    with pytest.raises(ParseError, match="non-finite"):
        _contact_balance(_damaged_contacts(tmp_path, poison("nan")))
    with pytest.raises(ParseError, match="not a number"):
        _contact_balance(_damaged_contacts(tmp_path / "b", poison("1.2e-0x")))


def test_contact_dump_with_a_broken_header(tmp_path):
    folder = _damaged_contacts(tmp_path, lambda t: t.replace("ITEM: NUMBER OF ENTRIES", "ITEM: NUMBER", 1))
    with pytest.raises(ParseError, match="malformed"):
        _contact_balance(folder)


def test_missing_or_empty_contact_dump(tmp_path):
    with pytest.raises(ParseError, match="missing"):
        read_local_frames(tmp_path / "pair_contacts.dump", len(CONTACT_COLUMNS))
    (tmp_path / "pair_contacts.dump").write_text("")
    with pytest.raises(ParseError, match="no frame"):
        read_local_frames(tmp_path / "pair_contacts.dump", len(CONTACT_COLUMNS))


def test_elastic_energy_of_the_wrong_length(tmp_path):
    with pytest.raises(ParseError, match="elastic energies"):
        read_cycles(CONTACTS / "power.txt", CONTACTS / "energy.txt", 1.0 / 500.0, CONTACT_CYCLES,
                    elastic_j=np.zeros(CONTACT_CYCLES))
