"""A design's cells as they are built: whole spheres, and what the surrogate says they give.

A design spends n_b spheres over n_c cells: n_b / n_c per cell is a whole number only by chance.
Built, every cell holds w = floor(n_b / n_c) spheres and L = n_b - w n_c of them one more
(``Design.whole_spheres_per_cell``, ``Design.spheres_left_over``). Its total C_eq is the sum over
its cells, each read where its sphere count puts it on the surrogate's fill axis (the fill a cell
holds, :func:`pidpipe.config.derived.cell_fill_pct`, as every row of the C_eq table is)::

    T(f, G) = [(n_c - L) C_eq(f, G, r_w) + L C_eq(f, G, r_(w+1))] / N,    r_k = 100 k / s_full

with N the coupon's cells. Reading the surrogate at the mean fill 100 (n_b / n_c) / s_full
instead gives a value between w and w + 1 spheres that no cell holds; the two differ by the
surrogate's curvature in fill between whole spheres. The optimiser still searches a continuous
fill (SLSQP needs one); the whole-cell design it reports, its band figures and its interval are
of the cells as built.
"""

from __future__ import annotations

import numpy as np

from pidpipe.config.derived import cell_fill_pct
from pidpipe.config.settings import Budget


def split_spheres(n_spheres: int, n_cells: int) -> tuple[int, int]:
    """(w, L): n spheres over c cells put w = floor(n / c) in every cell and one more in
    L = n - w c of them."""
    n_cells, n_spheres = int(n_cells), int(n_spheres)
    if n_cells < 1:
        raise ValueError(f"a design fills at least one cell, got {n_cells}")
    return divmod(n_spheres, n_cells)


def whole_sphere_counts(budget: Budget, n_cells: int) -> tuple[int, int]:
    """(w, L) of the budget's n_b spheres over n_c cells (:func:`split_spheres`)."""
    return split_spheres(int(round(budget.n_spheres)), n_cells)


def whole_sphere_cells(budget: Budget, n_cells: int,
                       fill_bounds: tuple[float, float] | None = None) -> list[tuple[float, int]]:
    """The cells of ``n_cells`` filled cells as built: (fill %, cells) for each sphere count.

    Parameters
    ----------
    budget : Budget
        ``n_spheres`` (n_b) and ``full_cell_spheres`` (s_full).
    n_cells : int
        Filled cells, n_c >= 1.
    fill_bounds : (float, float), optional
        The surrogate's fill domain, %: each fill is held to it (a surrogate fitted on fills
        other than whole-sphere ones, e.g. a table named by nominal fills, may end inside r_w).

    Returns
    -------
    list of (float, int)
        (r_w, n_c - L), then (r_(w+1), L) when L > 0 (:func:`whole_sphere_counts`); each fill
        :func:`pidpipe.config.derived.cell_fill_pct` of its count.
    """
    whole, left = whole_sphere_counts(budget, n_cells)
    counts = [(whole, int(n_cells) - left)] + ([(whole + 1, left)] if left else [])
    cells = []
    for spheres, cells_of_count in counts:
        fill = cell_fill_pct(spheres, budget.full_cell_spheres)
        if fill_bounds is not None:
            fill = float(np.clip(fill, *fill_bounds))
        cells.append((fill, cells_of_count))
    return cells


def cells_weights(cells: list[tuple[float, int]], n_cells_coupon: int) -> tuple[np.ndarray, np.ndarray]:
    """The fills r_k (%) and the weights n_k / N by which T sums the coupon's C_eq at them."""
    fills = np.array([fill for fill, _ in cells], dtype=float)
    weights = np.array([count for _, count in cells], dtype=float) / float(n_cells_coupon)
    return fills, weights


def at_each_fill(freq_hz, accel_g, fills) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points (f, G, r) of every (f, G) at every fill, fill by fill: 3 arrays of m * k, the
    first m at fills[0] (reshape a prediction at them to (k, m))."""
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    g = np.atleast_1d(np.asarray(accel_g, dtype=float))
    fills = np.atleast_1d(np.asarray(fills, dtype=float))
    return np.tile(f, fills.size), np.tile(g, fills.size), np.repeat(fills, f.size)


def cells_total(model, freq_hz, accel_g, cells: list[tuple[float, int]],
                n_cells_coupon: int) -> np.ndarray:
    """T at each (f, G): the built cells' total C_eq, N*s/m, shape of ``freq_hz``.

    Parameters
    ----------
    model
        Has ``predict(f, G, r)`` of the coupon's C_eq, N*s/m.
    freq_hz, accel_g : array_like, shape (m,)
        Hz, g.
    cells : list of (float, int)
        :func:`whole_sphere_cells`.
    n_cells_coupon : int
        N, the coupon's cells (the surrogate's C_eq is of N filled cells).
    """
    fills, weights = cells_weights(cells, n_cells_coupon)
    values = np.asarray(model.predict(*at_each_fill(freq_hz, accel_g, fills)), dtype=float)
    return weights @ values.reshape(fills.size, -1)
