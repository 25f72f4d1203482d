"""The panel's figure: each environment's mode shape with the optimised layout's filled cells over it."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pidpipe.figures.common import RC_PARAMS


def plot_panel_layouts(panels: list[dict], length_mm: float, width_mm: float) -> Figure:
    """One axes per entry: the mode shape as colour, the filled cells as dots coloured by fill.

    Parameters
    ----------
    panels : list of dict
        Each with ``title`` (str), ``shape`` (callable (x_mm, y_mm) -> w / w_antinode, arrays),
        ``x_mm``, ``y_mm`` (filled cells' centres, shape (k,)) and ``fill_pct`` (shape (k,)).
    length_mm, width_mm : float
        The plate's a and b, mm.
    """
    import matplotlib

    with matplotlib.rc_context(RC_PARAMS):
        n = max(len(panels), 1)
        figure = Figure(figsize=(7.0, 3.4 * n), layout="constrained")
        axes = np.atleast_1d(figure.subplots(n, 1, squeeze=False)[:, 0])
        x = np.linspace(0.0, length_mm, 211)
        y = np.linspace(0.0, width_mm, 131)
        xx, yy = np.meshgrid(x, y)
        for ax, panel in zip(axes, panels):
            shade = ax.contourf(xx, yy, panel["shape"](xx, yy), levels=np.linspace(-1, 1, 21),
                                cmap="RdBu_r", alpha=0.45)
            dots = ax.scatter(panel["x_mm"], panel["y_mm"], c=panel["fill_pct"], s=2.0,
                              cmap="viridis", vmin=0.0, vmax=100.0,
                              linewidths=0)
            ax.set_aspect("equal")
            ax.set_xlim(0, length_mm)
            ax.set_ylim(0, width_mm)
            ax.set_xlabel("x along the ribbon L (mm)")
            ax.set_ylabel("y along W (mm)")
            ax.set_title(panel["title"], fontsize=9)
            figure.colorbar(shade, ax=ax, label="mode shape w / w_antinode (m/m)", shrink=0.9)
            figure.colorbar(dots, ax=ax, label="fill r (%)", shrink=0.9)
        return figure
