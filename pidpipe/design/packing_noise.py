"""The errors cases share through their packings, and their covariance.

Cases of one fill are shaken on the same packings: every grid case of a fill on the pilot's
packings 0 .. k-1, every new case of the refinement loop at that fill too. A packing that damps
more than the average does so in every case that shakes it, so the errors of those cases' C_eq
are correlated, and a model that treats each row's SEM as independent noise averages away an
offset that the rows share and does not average out.

A row's value is a weighted mean of its cells' (weight w_ip on packing p: 1 / k for a plain
mean of k cells). Each cell's deviation from the row's mean, scaled to the error of the mean,

    u_ip = (x_ip - mean_i) / sqrt(k (k - 1))        (the row's "load" on packing p),

gives the row's packing variance v_i = sum_p u_ip^2 (its between-cells SEM squared), and two
rows on the same packings the correlation of their cells' deviations,
r_ij = sum_p u_ip u_jp / sqrt(v_i v_j). The raw sample covariance U U^T has rank at most
k - 1 per packing set; a GP given it finds combinations of rows in which the estimated offsets
cancel exactly and believes them free of the packings' error. The covariance used instead is
smooth (:func:`noise_covariance`):

    N_ij = rho(d_ij) * sqrt(v_i v_j) * O_ij   (i != j),    N_ii = max(noise_i, v_i),

with O_ij = sum_p w_ip w_jp / sqrt(sum_p w_ip^2 sum_p w_jp^2) the overlap of the two rows'
packing weights (1 for rows on the same packings, 0 for rows of other fills) and rho(d) the
correlation of the cells' deviations as a function of the distance d between the two rows'
conditions in (ln f, ln G) (:class:`Correlation`): 1 at d = 0, falling over a length to a
floor, both fitted by least squares to the r_ij of every pair of rows that share packings.
A packing's offset is not one number: on the default LIGGGHTS campaigns' tables, pairs of rows
0.2-0.5 apart correlated 0.70-0.72 and pairs more than 1 apart about 0
(``benchmarks/experiments/shared_packings_verify.py``, docs/explanation/designs.md). N is positive
semi-definite (Schur products of positive semi-definite matrices, plus a non-negative
diagonal); for the rows of one packing set at one condition its shared part is one offset,
which no combination of those rows removes.

A packing is named by its fill (rounded to :data:`FILL_DECIMALS` %) and its seed; the loads are
kept in the table's text column :data:`LOADS_COLUMN` as ``seed:weight:load;...``, the load in
the row's C_eq unit (N*s/m of the coupon). A row averaged from several parts (replicates, or the
loop's extensions pooled by inverse variance) carries each part's weights and loads times the
part's weight (:func:`combine_loads`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

import numpy as np

from pidpipe.config.derived import FILL_DECIMALS

#: The table's column of a row's packing loads.
LOADS_COLUMN = "packing_loads"

#: Significant digits a load is written with.
LOAD_DIGITS = 9

#: Packings two rows must share for their cells' deviations to enter the fitted correlation.
MIN_SHARED = 3

#: Lengths the correlation's fall is fitted over (ln units of f and G).
LENGTHS = np.geomspace(0.05, 5.0, 41)


# A row's loads: seed -> (weight of the packing in the row's mean, load in the row's unit).
Loads = dict[int, tuple[float, float]]


def cell_loads(values: Sequence[float], seeds: Sequence[int], scale: float = 1.0) -> Loads:
    """The loads of a row measured as the plain mean of k cells.

    Parameters
    ----------
    values : sequence of float, length k
        Each cell's C_eq (any unit; ``scale`` turns it into the row's).
    seeds : sequence of int, length k
        Each cell's packing seed, in the same order.
    scale : float
        The row's value per cell value (the coupon's cells, for a coupon C_eq).

    Returns
    -------
    dict
        seed -> (1 / k, u); empty for fewer than two cells or any value not finite.
    """
    x = np.asarray(values, dtype=float)
    k = x.size
    if k < 2 or len(seeds) != k or not np.all(np.isfinite(x)) or not math.isfinite(scale):
        return {}
    loads = (x - x.mean()) / math.sqrt(k * (k - 1)) * scale
    return combine_loads([{int(seed): (1.0 / k, float(load))} for seed, load in zip(seeds, loads)],
                         [1.0] * k)


def combine_loads(parts: Iterable[Mapping[int, tuple[float, float]]],
                  weights: Iterable[float]) -> Loads:
    """The loads of a row that is the weighted sum of parts (weights summing to one)."""
    out: Loads = {}
    for part, weight in zip(parts, weights):
        for seed, (w, load) in part.items():
            before = out.get(int(seed), (0.0, 0.0))
            out[int(seed)] = (before[0] + float(weight) * w, before[1] + float(weight) * load)
    return out


def format_loads(loads: Mapping[int, tuple[float, float]]) -> str:
    """``seed:weight:load;...`` in seed order (empty text for no loads)."""
    return ";".join(f"{int(seed)}:{loads[seed][0]:.{LOAD_DIGITS}g}:{loads[seed][1]:.{LOAD_DIGITS}g}"
                    for seed in sorted(loads))


def parse_loads(text) -> Loads:
    """The loads of :func:`format_loads` text; empty for a missing value (NaN, None, "").

    Raises
    ------
    ValueError
        Text that is not ``seed:weight:load`` triples.
    """
    if text is None or (isinstance(text, float) and math.isnan(text)) or not str(text).strip():
        return {}
    out: Loads = {}
    for triple in str(text).split(";"):
        parts = triple.split(":")
        if len(parts) != 3:
            raise ValueError(f"packing load {triple!r} is not seed:weight:load")
        out[int(parts[0])] = (float(parts[1]), float(parts[2]))
    return out


def scaled_loads(loads: Mapping[int, tuple[float, float]], factor: float) -> Loads:
    """The loads with every load (not weight) times ``factor``."""
    return {seed: (w, load * factor) for seed, (w, load) in loads.items()}


def load_matrices(fill_pct: Sequence[float], loads: Sequence) -> tuple[np.ndarray, np.ndarray]:
    """W and U: one row per table row, one column per packing (fill, seed).

    Parameters
    ----------
    fill_pct : sequence of float, length n
        Each row's fill, %.
    loads : sequence, length n
        Each row's loads: text of :func:`format_loads`, a mapping, or None.

    Returns
    -------
    weights, loads : numpy.ndarray, shape (n, P)
        P the number of packings any row loads (0 columns when none does); loads in row units.
    """
    rows = [part if isinstance(part, Mapping) else parse_loads(part) for part in loads]
    names: dict[tuple[float, int], int] = {}
    for fill, part in zip(fill_pct, rows):
        for seed in sorted(part):
            names.setdefault((round(float(fill), FILL_DECIMALS), seed), len(names))
    weights, matrix = np.zeros((len(rows), len(names))), np.zeros((len(rows), len(names)))
    for i, (fill, part) in enumerate(zip(fill_pct, rows)):
        for seed, (w, load) in part.items():
            column = names[(round(float(fill), FILL_DECIMALS), seed)]
            weights[i, column], matrix[i, column] = w, load
    return weights, matrix


def overlap(weights: np.ndarray) -> np.ndarray:
    """O_ij, the cosine of two rows' packing weights, shape (n, n) (0 for a row without)."""
    norm = np.sqrt(np.sum(weights**2, axis=1))
    unit = np.divide(weights, norm[:, None], out=np.zeros_like(weights), where=norm[:, None] > 0)
    return unit @ unit.T


def pair_correlations(weights: np.ndarray, loads: np.ndarray) -> tuple[np.ndarray, ...]:
    """The correlation of the cells' deviations of every pair of rows sharing at least
    :data:`MIN_SHARED` packings, over the packings they share.

    Returns
    -------
    i, j : numpy.ndarray of int
        The pairs' rows (i < j).
    r : numpy.ndarray
        sum_p u_ip u_jp / sqrt(sum_p u_ip^2 sum_p u_jp^2), sums over the shared packings.
    """
    present = (weights > 0).astype(float)
    shared = present @ present.T
    products = loads @ loads.T
    squares = loads**2
    own_i, own_j = squares @ present.T, present @ squares.T   # v_i and v_j over the shared packings
    i, j = np.nonzero(np.triu(shared >= MIN_SHARED, k=1))
    denominator = np.sqrt(own_i[i, j] * own_j[i, j])
    good = denominator > 0
    return i[good], j[good], products[i, j][good] / denominator[good]


@dataclass(frozen=True)
class Correlation:
    """rho(d) = floor + (1 - floor) exp(-d^2 / (2 length^2)): how the correlation of two rows'
    packing errors falls with the distance d between their conditions, in (ln f, ln G).

    Attributes
    ----------
    floor : float
        The correlation of rows far apart, in [0, 1].
    length : float
        The distance over which it falls from 1 to the floor (ln units).
    pairs : int
        Pairs of rows sharing packings it was fitted to (0: none, and then no correlation).
    """

    floor: float
    length: float
    pairs: int

    def __call__(self, distance: np.ndarray) -> np.ndarray:
        if self.pairs == 0:
            return np.where(np.asarray(distance) == 0, 1.0, 0.0)
        return self.floor + (1.0 - self.floor) * np.exp(-0.5 * (np.asarray(distance) / self.length) ** 2)

    @classmethod
    def fit(cls, distance: np.ndarray, r: np.ndarray) -> "Correlation":
        """Least squares over the pairs: for each length of :data:`LENGTHS`, the best floor
        (closed form, clipped to [0, 1]); the pair with the smallest residual."""
        distance, r = np.asarray(distance, dtype=float), np.asarray(r, dtype=float)
        if r.size == 0:
            return cls(0.0, float(LENGTHS[0]), 0)
        best = None
        for length in LENGTHS:
            near = np.exp(-0.5 * (distance / length) ** 2)
            rest = 1.0 - near
            floor = float(np.clip(np.sum((r - near) * rest) / max(np.sum(rest**2), 1e-300), 0.0, 1.0))
            residual = float(np.sum((r - floor - (1.0 - floor) * near) ** 2))
            if best is None or residual < best[0] - 1e-12:
                best = (residual, floor, float(length))
        return cls(best[1], best[2], int(r.size))


def condition_distance(freq_hz: np.ndarray, accel_g: np.ndarray) -> np.ndarray:
    """d_ij = sqrt((ln f_i - ln f_j)^2 + (ln G_i - ln G_j)^2), shape (n, n)."""
    u = np.column_stack([np.log(np.asarray(freq_hz, dtype=float)),
                         np.log(np.asarray(accel_g, dtype=float))])
    return np.sqrt(np.sum((u[:, None, :] - u[None, :, :]) ** 2, axis=-1))


def noise_covariance(weights: np.ndarray, loads: np.ndarray, noise: np.ndarray,
                     correlation: np.ndarray) -> np.ndarray:
    """The rows' noise covariance of the module's text.

    Parameters
    ----------
    weights, loads : numpy.ndarray, shape (n, P)
        W and U (:func:`load_matrices`); U in the units of the noise's square root.
    noise : numpy.ndarray, shape (n,)
        Each row's own noise variance (its SEM squared, transformed as the model's values).
    correlation : numpy.ndarray, shape (n, n)
        rho(d_ij) (:class:`Correlation` of :func:`condition_distance`), positive semi-definite
        with ones on its diagonal.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        Symmetric, positive semi-definite; its diagonal is max(noise_i, v_i).
    """
    v = np.sum(loads**2, axis=1)
    sd = np.sqrt(v)
    shared = correlation * np.outer(sd, sd) * overlap(weights)
    diagonal = np.maximum(np.asarray(noise, dtype=float), v)
    np.fill_diagonal(shared, 0.0)
    return shared + np.diag(diagonal)


@dataclass(frozen=True)
class SharedPackings:
    """The packings a table's rows share: W, U (row units), their conditions and the fitted
    correlation.

    Attributes
    ----------
    weights, loads : numpy.ndarray, shape (n, P)
        :func:`load_matrices`.
    distance : numpy.ndarray, shape (n, n)
        :func:`condition_distance` of the rows.
    correlation : Correlation
        Fitted to the rows' :func:`pair_correlations`.
    """

    weights: np.ndarray
    loads: np.ndarray
    distance: np.ndarray
    correlation: Correlation

    @classmethod
    def of(cls, table) -> "SharedPackings | None":
        """The shared packings of a table's rows (``fill_pct``, ``freq_hz``, ``accel_g`` and
        :data:`LOADS_COLUMN`); None when the table has no loads or no two rows share a packing."""
        if LOADS_COLUMN not in table:
            return None
        weights, matrix = load_matrices(np.asarray(table["fill_pct"], dtype=float),
                                        list(table[LOADS_COLUMN]))
        if not np.any(np.count_nonzero(weights, axis=0) > 1):
            return None
        distance = condition_distance(table["freq_hz"], table["accel_g"])
        i, j, r = pair_correlations(weights, matrix)
        return cls(weights, matrix, distance, Correlation.fit(distance[i, j], r))

    def covariance(self, noise: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
        """:func:`noise_covariance` with the loads times ``scale`` row by row (the slope of a
        target transform)."""
        loads = self.loads if scale is None else self.loads * np.asarray(scale, dtype=float)[:, None]
        return noise_covariance(self.weights, loads, noise, self.correlation(self.distance))

    def describe(self) -> str:
        """One line: the fitted correlation and what it was fitted to."""
        c = self.correlation
        return (f"packing errors correlated {c.floor:.2f} + {1 - c.floor:.2f} exp(-d^2 / 2 "
                f"({c.length:.2f})^2) over d in (ln f, ln G), from {c.pairs} pairs of rows "
                f"sharing packings")
