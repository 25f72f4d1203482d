"""The damping regime of a case, read from the bed's motion over the measured cycles.

Each cell's measured cycles give, from the windows of a :class:`~pidpipe.measurement.motion.BedMotion`
(binned by phase as in :mod:`pidpipe.measurement.phase`):

- **flight**: the bed is airborne in a window when the floor carries less than
  :data:`AIRBORNE_FRACTION` of its weight; a cycle's flight is the fraction of its windows that
  are airborne, and the cycle *lifts off* if that is at least :data:`LIFT_OFF_FLIGHT` (a bed that
  follows the floor at G = 1 is unloaded, below 2 % of its weight, for 6 % of the cycle);
- **landings**: airborne windows followed by a loaded one, per cycle, and the phase of the first;
- **lid contact**: a cycle touches the lid if the lid carries more than :data:`LID_FRACTION` of
  the bed's weight in any window; the **lid peak** is the largest lid force of any phase bin of
  any cycle (the impacts' strength at the windows' resolution: a phase-mean over the cycles
  smears impacts that come at scattered phases, and one impact can carry the whole cycle);
- **expansion**: the mean over the cycle of the bed's height (highest minus lowest sphere centre)
  above its height at rest, in sphere diameters;
- **alternation**: d1 and d2, the RMS difference of the flight between cycles one and two apart.
  A bed that alternates between a long and a short flight (period doubling) has d2 much
  smaller than d1;
- **landing scatter**: the median absolute deviation of the landing phase from its circular
  median, in cycles.

A cell's regime is the first of these that holds (:func:`classify`):

1. ``no_lift_off``: fewer than :data:`LIFT_OFF_CYCLES` of the cycles lift off, and the lid is
   never touched: the bed moves with the floor;
2. ``lid_impacts``: at least :data:`LID_CYCLES` of the cycles touch the lid;
3. ``fluidised``: the mean expansion exceeds :data:`FLUIDISED_EXPANSION` diameters: the spheres fly
   apart instead of moving as one bed;
4. ``period_doubling``: d1 > :data:`ALTERNATION_NOISE` and d2 < :data:`DOUBLING_RATIO` x d1;
5. ``bouncing_bed``: one landing a cycle (median), at the same phase (landing scatter below
   :data:`LANDING_SCATTER`);
6. ``irregular``: it lifts off, but lands neither once a cycle at one phase nor every other cycle.

The case's regime is the one most of its cells are in (ties go to the earlier regime of the list).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass, fields

import numpy as np

from pidpipe.measurement.motion import BedMotion
from pidpipe.measurement.phase import cycle_bins, per_cycle

NO_LIFT_OFF = "no_lift_off"
LID_IMPACTS = "lid_impacts"
FLUIDISED = "fluidised"
PERIOD_DOUBLING = "period_doubling"
BOUNCING_BED = "bouncing_bed"
IRREGULAR = "irregular"
REGIMES = (NO_LIFT_OFF, LID_IMPACTS, FLUIDISED, PERIOD_DOUBLING, BOUNCING_BED, IRREGULAR)
"""Every regime, in the order :func:`classify` tries them."""

AIRBORNE_FRACTION = 0.02
"""The bed is airborne in a window where the floor carries less than this fraction of its weight."""
LIFT_OFF_FLIGHT = 0.15
"""A cycle lifts off if the bed is airborne for at least this fraction of it (3 windows of 20)."""
LID_FRACTION = 0.02
"""A cycle touches the lid where the lid carries more than this fraction of the bed's weight."""
LIFT_OFF_CYCLES = 0.1
"""Below this fraction of lifting-off cycles (and no lid contact) the bed does not lift off."""
LID_CYCLES = 0.1
"""From this fraction of cycles touching the lid on, the regime is lid impacts."""
FLUIDISED_EXPANSION = 1.0
"""Mean expansion of the bed above its height at rest, in sphere diameters, beyond which it is
fluidised (a whole extra layer of space: the spheres no longer move as one bed)."""
ALTERNATION_NOISE = 0.1
"""Flight differences between consecutive cycles below this (fraction of a cycle, RMS) are no
alternation."""
DOUBLING_RATIO = 0.5
"""Period doubling: cycles two apart are at least twice as alike as consecutive ones."""
LANDING_SCATTER = 0.1
"""A bouncing bed lands within this (median absolute deviation, cycles) of one phase."""


@dataclass(frozen=True)
class CellMotionFeatures:
    """What one cell's measured cycles show (see the module docstring).

    Attributes
    ----------
    n_cycles : int
    lift_off_cycles, lid_cycles : float
        Fraction of the cycles that lift off, that touch the lid.
    lid_peak : float
        Largest force on the lid in one phase bin of one cycle, in bed weights (0 if the lid is
        never touched).
    flight : float
        Fraction of the cycle the bed is airborne, mean over the cycles.
    landings_per_cycle : float
        Median landings per cycle.
    landing_phase, landing_scatter : float
        Circular median of the first landing's phase in a cycle and the median absolute
        deviation from it, in cycles (NaN without landings).
    expansion_diameters : float
        Mean expansion above the bed's height at rest, sphere diameters.
    d1, d2 : float
        RMS difference of the flight between cycles one and two apart (fraction of a cycle).
    """

    n_cycles: int
    lift_off_cycles: float
    lid_cycles: float
    lid_peak: float
    flight: float
    landings_per_cycle: float
    landing_phase: float
    landing_scatter: float
    expansion_diameters: float
    d1: float
    d2: float


def cell_features(floor_profile: np.ndarray, lid_profile: np.ndarray,
                  height_profile: np.ndarray, rest_height_m: float, radius_m: float) -> CellMotionFeatures:
    """The features of one cell from its per-cycle profiles.

    Parameters
    ----------
    floor_profile, lid_profile : ndarray, shape (n_cycles, bins)
        Floor and lid force per phase bin of each measured cycle, in bed weights (NaN: no window).
    height_profile : ndarray, shape (n_cycles, bins)
        Bed height (highest minus lowest sphere centre) per phase bin, m.
    rest_height_m : float
        The bed's height at rest, m.
    radius_m : float
        Sphere radius, m.
    """
    floor = np.asarray(floor_profile, dtype=float)
    n_cycles, bins = floor.shape
    nan = float("nan")
    if n_cycles == 0:
        return CellMotionFeatures(0, *[nan] * (len(fields(CellMotionFeatures)) - 1))
    # The windows in time order across the cycles, to find landings (airborne -> loaded).
    present = ~np.isnan(floor.reshape(-1))
    airborne = floor.reshape(-1)[present] < AIRBORNE_FRACTION
    cycle_of = np.repeat(np.arange(n_cycles), bins)[present]
    bin_of = np.tile(np.arange(bins), n_cycles)[present]
    landing = np.zeros(airborne.size, dtype=bool)
    landing[1:] = airborne[:-1] & ~airborne[1:]
    landings = np.bincount(cycle_of[landing], minlength=n_cycles)
    windows = np.maximum(np.bincount(cycle_of, minlength=n_cycles), 1)
    flight = np.bincount(cycle_of[airborne], minlength=n_cycles) / windows
    first = {}
    for cycle, phase_bin in zip(cycle_of[landing], bin_of[landing]):
        first.setdefault(int(cycle), (phase_bin + 0.5) / bins)
    phases = np.array(list(first.values()))
    landing_phase, landing_scatter = _circular_median(phases) if phases.size else (nan, nan)
    lid_cycle_peak = np.where(np.isnan(lid_profile), -np.inf, lid_profile).max(axis=1)
    lid_touch = lid_cycle_peak > LID_FRACTION
    expansion = (np.nanmean(height_profile) - rest_height_m) / (2.0 * radius_m)

    def distance(lag: int) -> float:
        return float(np.sqrt(np.mean((flight[lag:] - flight[:-lag]) ** 2))) if n_cycles > lag else nan

    return CellMotionFeatures(
        n_cycles=int(n_cycles), lift_off_cycles=float(np.mean(flight >= LIFT_OFF_FLIGHT)),
        lid_cycles=float(np.mean(lid_touch)), lid_peak=float(max(lid_cycle_peak.max(), 0.0)),
        flight=float(np.mean(flight)),
        landings_per_cycle=float(np.median(landings)), landing_phase=float(landing_phase),
        landing_scatter=float(landing_scatter), expansion_diameters=float(expansion),
        d1=distance(1), d2=distance(2))


def _circular_median(phases: np.ndarray) -> tuple[float, float]:
    """The phase (cycles, in [0, 1)) that minimises the median circular distance to ``phases``,
    and that median distance; the candidates are the phases themselves."""
    gaps = np.abs(phases[:, None] - phases[None, :])
    gaps = np.minimum(gaps, 1.0 - gaps)
    spread = np.median(gaps, axis=1)
    best = int(np.argmin(spread))
    return float(phases[best]), float(spread[best])


def classify(features: CellMotionFeatures) -> str:
    """The regime of one cell (the rules of the module docstring, in order)."""
    f = features
    if f.lift_off_cycles < LIFT_OFF_CYCLES and f.lid_cycles == 0.0:
        return NO_LIFT_OFF
    if f.lid_cycles >= LID_CYCLES:
        return LID_IMPACTS
    if f.expansion_diameters > FLUIDISED_EXPANSION:
        return FLUIDISED
    if np.isfinite(f.d2) and f.d1 > ALTERNATION_NOISE and f.d2 < DOUBLING_RATIO * f.d1:
        return PERIOD_DOUBLING
    if f.landings_per_cycle == 1 and f.landing_scatter < LANDING_SCATTER:
        return BOUNCING_BED
    return IRREGULAR


def case_regime(cell_regimes: list[str]) -> str:
    """The regime most cells are in; a tie goes to the regime earlier in :data:`REGIMES`."""
    counts = Counter(cell_regimes)
    return max(REGIMES, key=lambda name: (counts.get(name, 0), -REGIMES.index(name)))


def motion_regime(motion: BedMotion, first_cycle: int, bins: int, rest_height_m) -> dict:
    """The regime of a run and of each of its cells, with the features that decided it.

    Parameters
    ----------
    motion : BedMotion
    first_cycle : int
        The first measured cycle.
    bins : int
        Phase bins per cycle (at most the windows per cycle).
    rest_height_m : array_like, shape (n_cells,)
        Each cell's bed height at rest (highest minus lowest sphere centre of its packing), m.

    Returns
    -------
    dict
        ``regime`` (the case's), ``cell_regimes`` (list), ``cell_features`` (list of dicts of
        :class:`CellMotionFeatures`).
    """
    cycle, phase_bin, n_cycles = cycle_bins(motion, first_cycle, bins)
    weight = motion.weight_n
    floor = per_cycle(motion.floor_force_n / weight, cycle, phase_bin, n_cycles, bins)
    lid = per_cycle(motion.lid_force_n / weight, cycle, phase_bin, n_cycles, bins)
    height = per_cycle(motion.top_m - motion.bottom_m, cycle, phase_bin, n_cycles, bins)
    rest = np.broadcast_to(np.asarray(rest_height_m, dtype=float), (motion.n_cells,))
    features = [cell_features(floor[:, :, k], lid[:, :, k], height[:, :, k], rest[k], motion.radius_m)
                for k in range(motion.n_cells)]
    regimes = [classify(f) for f in features]
    return {"regime": case_regime(regimes), "cell_regimes": regimes,
            "cell_features": [asdict(f) for f in features]}
