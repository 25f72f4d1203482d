"""What the loop may run: new cases around the designs, extensions of existing ones, and the
designs' verifying points.

Every point is at a whole-sphere fill: the design's fill r_d is poured as n = round half up of
(full_cell_spheres * r_d / 100) spheres, at fill 100 n / full_cell_spheres
(:func:`pidpipe.config.derived.poured_fill`), as every case of the campaign is.

New cases (:func:`new_case_candidates`)
    For a band design (``band_mean``, ``worst_case``): the 3 x 3 points of its band (corners,
    edge midpoints, centre) at its poured fill, and the band's centre at one sphere fewer and
    one more. For the ``peak`` design: its point (f*, G*) at its poured fill and at one sphere
    fewer and one more. Points whose key the fitted table already has are not new (they are
    extension candidates instead).
Extensions (:func:`extend_candidates`)
    Fitted rows with a SEM near a design: f and G within the band widened by half its width on
    each side, r within two spheres of the design's poured fill.
Verifying points (:func:`verify_points`)
    The band's four corners and centre at the design's poured fill
    (:func:`pidpipe.loop.verify.band_points`), for every design kind verified.

The surrogate is read at the point's own fill (the fill the DEM pours), not at r_d: a verifying
point is compared with what the surrogate says the poured cell gives.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import SEM_COLUMN
from pidpipe.config.derived import poured_fill
from pidpipe.loop.verify import band_points
from pidpipe.refine.table import KEY_DECIMALS, case_key

if TYPE_CHECKING:  # only named in annotations: the Snakefile imports this module, not SciPy
    from pidpipe.design.optimisation import OptimisationResult

#: Effort (cells x cycles) after an extension over the effort before: 4 halves the SEM.
EXTEND_FACTOR = 4.0


@dataclass(frozen=True)
class Request:
    """One case for the engine to run.

    Attributes
    ----------
    freq_hz, accel_g, fill_pct : float
        The case (Hz, g, %).
    action : str
        ``new``, ``extend``, ``verify`` or ``reverify`` (another verifying run of a point).
    reason : str
        Why it was chosen.
    factor : float
        ``extend``: effort after over effort before (:data:`EXTEND_FACTOR`); 1 otherwise.
    base : dict
        ``extend``: the row extended (its columns); empty otherwise.
    designs : tuple of str
        The designs (``environment/kind``) it serves.
    run : int
        Which run of the case this is: 0 for a first run, the count of earlier verifying runs
        for a ``reverify`` (so that an engine seeds it apart from them).
    """

    freq_hz: float
    accel_g: float
    fill_pct: float
    action: str = "new"
    reason: str = ""
    factor: float = 1.0
    base: dict = field(default_factory=dict, compare=False, hash=False)
    designs: tuple[str, ...] = ()
    run: int = 0

    def __post_init__(self) -> None:
        # the coordinates as the table's key has them: a band's corner computed in floating
        # point (800 Hz at 4.000000000000006 g) is the case 800 Hz, 4 g, not a case of its own id
        for name, decimals in KEY_DECIMALS.items():
            object.__setattr__(self, name, round(float(getattr(self, name)), decimals))

    @property
    def key(self) -> str:
        return case_key(self.freq_hz, self.accel_g, self.fill_pct)


def design_name(result: OptimisationResult) -> str:
    """``environment/kind`` of a design."""
    return f"{result.environment.name}/{result.kind}"


def whole_sphere_fills(fill_pct: float, full_cell_spheres: int, around: bool) -> list[float]:
    """The poured fill of ``fill_pct`` (and with ``around``, one sphere fewer and more), %."""
    fill, n = poured_fill(fill_pct, full_cell_spheres)
    fills = [fill]
    if around:
        for other in (n - 1, n + 1):
            if 1 <= other <= full_cell_spheres:
                fills.append(round(100.0 * other / full_cell_spheres, 3))
    return fills


def design_points(result: OptimisationResult,
                  full_cell_spheres: int) -> list[tuple[float, float, float]]:
    """New-case points (f Hz, G g, r %) of one design (see the module's text)."""
    (f_lo, f_hi), (g_lo, g_hi) = result.bounds["freq_hz"], result.bounds["accel_g"]
    if result.kind == "peak":
        f0, g0 = float(result.design.freq_hz), float(result.design.accel_g)
        fills = whole_sphere_fills(result.design.fill_pct, full_cell_spheres, True)
        return [(f0, g0, r) for r in fills]
    fill, *around = whole_sphere_fills(result.design.fill_pct, full_cell_spheres, True)
    fs = (f_lo, 0.5 * (f_lo + f_hi), f_hi)
    gs = (g_lo, 0.5 * (g_lo + g_hi), g_hi)
    points = [(f, g, fill) for f in fs for g in gs]
    return points + [(fs[1], gs[1], r) for r in around]


def new_case_candidates(results: list[OptimisationResult], full_cell_spheres: int,
                        fitted_keys: set[str]) -> list[Request]:
    """New cases around the designs, one per key (the designs it serves listed), sorted by key."""
    by_key: dict[str, Request] = {}
    for result in results:
        for f, g, r in design_points(result, full_cell_spheres):
            request = Request(float(f), float(g), float(r), "new", designs=(design_name(result),))
            if request.key in fitted_keys:
                continue
            if request.key in by_key:
                old = by_key[request.key]
                request = Request(old.freq_hz, old.accel_g, old.fill_pct, "new",
                                  designs=old.designs + request.designs)
            by_key[request.key] = request
    return [by_key[k] for k in sorted(by_key)]


def near_design(rows: pd.DataFrame, result: OptimisationResult,
                full_cell_spheres: int) -> np.ndarray:
    """Which rows lie near a design (see the module's text); bool, shape (n_rows,)."""
    (f_lo, f_hi), (g_lo, g_hi) = result.bounds["freq_hz"], result.bounds["accel_g"]
    df, dg = 0.5 * (f_hi - f_lo), 0.5 * (g_hi - g_lo)
    fill, _ = poured_fill(result.design.fill_pct, full_cell_spheres)
    dr = 2.0 * 100.0 / full_cell_spheres + 1e-9
    f, g, r = (rows[c].to_numpy(dtype=float) for c in ("freq_hz", "accel_g", "fill_pct"))
    return ((f >= f_lo - df) & (f <= f_hi + df) & (g >= g_lo - dg) & (g <= g_hi + dg)
            & (np.abs(r - fill) <= dr))


def extend_candidates(fitted: pd.DataFrame, results: list[OptimisationResult],
                      full_cell_spheres: int) -> list[Request]:
    """Extensions of fitted rows (status ok, finite SEM > 0) near a design, sorted by key."""
    ok = fitted[(fitted["status"] == "ok") & np.isfinite(fitted[SEM_COLUMN].to_numpy(dtype=float))
                & (fitted[SEM_COLUMN].to_numpy(dtype=float) > 0)]
    serves: dict[str, list[str]] = {}
    for result in results:
        for key in ok.loc[near_design(ok, result, full_cell_spheres), "case_key"]:
            serves.setdefault(key, []).append(design_name(result))
    requests = []
    for key in sorted(serves):
        row = ok[ok["case_key"] == key].iloc[-1]
        point = (float(row["freq_hz"]), float(row["accel_g"]), float(row["fill_pct"]))
        requests.append(Request(*point, "extend", factor=EXTEND_FACTOR, base=row.to_dict(),
                                designs=tuple(serves[key])))
    return requests


def verify_points(results: list[OptimisationResult], full_cell_spheres: int) -> pd.DataFrame:
    """Every design's verifying points: one row per design and point.

    Returns
    -------
    pandas.DataFrame
        ``design`` (environment/kind), ``point`` (corner or centre name), ``freq_hz``,
        ``accel_g``, ``design_fill_pct`` (r_d), ``fill_pct`` (poured), ``case_key``; in the
        order of ``results``, then the points' order.
    """
    rows = []
    for result in results:
        fill, _ = poured_fill(result.design.fill_pct, full_cell_spheres)
        for name, f, g in band_points(result.bounds["freq_hz"], result.bounds["accel_g"]):
            rows.append({"design": design_name(result), "point": name, "freq_hz": f, "accel_g": g,
                         "design_fill_pct": float(result.design.fill_pct), "fill_pct": fill,
                         "case_key": case_key(f, g, fill)})
    return pd.DataFrame(rows, columns=["design", "point", "freq_hz", "accel_g", "design_fill_pct",
                                       "fill_pct", "case_key"])
