"""How long each grid case's pilot runs: full pilots where an environment's band lies, short
ones elsewhere.

With the refinement loop and no uniform target, the grid's pilots are what the loop starts
from, and the designs read the surrogate only inside the environments' bands. A grid point
whose frequency and acceleration levels do not bracket any band is read by no design: its
pilot screens the surface (the maps, the surrogate's shape far from the bands) and runs
``refine.far_pilot_measured_cycles`` measured cycles instead of ``fidelity.measured_cycles``.
A case lasts a fixed number of cycles, so its CPU grows as 1/f: on the default LIGGGHTS
campaign the 50 Hz pilots, which bracket no band, took 55 % of the pilots' engine CPU
(docs/explanation/refine.md).

A short pilot keeps every cell of a full one (``fidelity.cells_per_run``), so its standard
error still carries the scatter between packings; it is larger, and the surrogate weighs the
point by it. Its record and the table's ``measured_cycles`` say what it ran.
"""

from __future__ import annotations

import bisect
from typing import Sequence

from pidpipe.config.stages import stage_config


def bracketing_levels(levels: Sequence[float], low: float, high: float) -> tuple[float, ...]:
    """The grid levels that bracket the band [low, high]: from the largest level <= low to the
    smallest level >= high, every level between included.

    A band below the lowest level starts at the lowest, one above the highest ends at the
    highest (:func:`pidpipe.config.schema.check_environments_in_reach` refuses both before a
    campaign runs).

    Parameters
    ----------
    levels : sequence of float
        The grid's levels of one axis (Hz or g), in any order.
    low, high : float
        The band's ends, low <= high (same unit).

    Returns
    -------
    tuple of float
        Sorted ascending.
    """
    ordered = sorted(float(level) for level in levels)
    first = max(bisect.bisect_right(ordered, float(low)) - 1, 0)
    last = min(bisect.bisect_left(ordered, float(high)), len(ordered) - 1)
    return tuple(ordered[first:last + 1])


def band_points(config: dict) -> set[tuple[float, float]]:
    """The grid's (f, G) points that some environment's band reads: both levels bracket that
    band (:func:`bracketing_levels`). Every fill at such a point runs a full pilot.

    Parameters
    ----------
    config : dict
        A validated config.

    Returns
    -------
    set of (float, float)
        (frequency in Hz, acceleration in g).
    """
    grid = config["grid"]
    points = set()
    for environment in config["environments"]:
        freqs = bracketing_levels(grid["freq_hz"], *environment["freq_hz"])
        accels = bracketing_levels(grid["accel_g"], *environment["accel_g"])
        points.update((f, g) for f in freqs for g in accels)
    return points


def screens_far_points(config: dict) -> bool:
    """Whether the grid's pilots away from the bands run short: the loop is on, no uniform
    target chases every case, an external C_eq table does not replace the campaign's, and
    ``refine.far_pilot_measured_cycles`` is set."""
    return (bool(config["refine"].get("enabled", False))
            and config["fidelity"]["target_relative_sem"] is None
            and config["optimisation"].get("external_ceq_table") is None
            and config["refine"].get("far_pilot_measured_cycles") is not None)


def pilot_measured_cycles(config: dict, freq_hz: float, accel_g: float) -> int:
    """Measured cycles of the pilot of grid point (f, G), every fill alike.

    Parameters
    ----------
    config : dict
        A validated config.
    freq_hz : float
        Base frequency, Hz.
    accel_g : float
        Base acceleration amplitude, g.

    Returns
    -------
    int
        ``fidelity.measured_cycles``, or at a point no band reads when the loop screens
        (:func:`screens_far_points`) the smaller of it and ``refine.far_pilot_measured_cycles``.
    """
    full = int(config["fidelity"]["measured_cycles"])
    if not screens_far_points(config) or (float(freq_hz), float(accel_g)) in band_points(config):
        return full
    return min(full, int(config["refine"]["far_pilot_measured_cycles"]))


def grid_case_config(config: dict, freq_hz: float, accel_g: float) -> dict:
    """The case stage's part of the config (:func:`~pidpipe.config.stages.stage_config`) for the
    grid's cases at (f, G): ``fidelity.measured_cycles`` is the point's pilot
    (:func:`pilot_measured_cycles`). A rule's ``params``: a point whose pilot changes length is
    rerun, the others are not. Parameters as :func:`pilot_measured_cycles`'s (f in Hz, G in g).

    Returns
    -------
    dict
    """
    part = stage_config(config, "case")
    part["fidelity"]["measured_cycles"] = pilot_measured_cycles(config, freq_hz, accel_g)
    return part


def short_pilot_points(config: dict) -> list[tuple[float, float]]:
    """The grid's (f, G) points whose pilot runs short (:func:`pilot_measured_cycles`), sorted;
    empty when the loop does not screen."""
    grid, full = config["grid"], int(config["fidelity"]["measured_cycles"])
    return [(float(f), float(g)) for f in sorted(grid["freq_hz"]) for g in sorted(grid["accel_g"])
            if pilot_measured_cycles(config, f, g) < full]
