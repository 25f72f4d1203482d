"""What every figure shares: axis labels with units, the colour floor, saving as PNG and PDF.

Figures are built with :class:`matplotlib.figure.Figure` (Agg canvas), so importing this package
does not change pyplot's backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import rc_context, rcParams
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

CEQ_LABEL = r"$C_\mathrm{eq}$ (N·s/m)"

AXIS_LABELS = {"freq_hz": "frequency f (Hz)", "accel_g": "base acceleration G (g)",
                "fill_pct": "fill fraction r (%)"}

UNITS = {"freq_hz": "Hz", "accel_g": "g", "fill_pct": "%"}

SYMBOLS = {"freq_hz": "f", "accel_g": "G", "fill_pct": "r"}

RC_PARAMS = {"font.size": 11, "axes.titlesize": 11, "axes.labelsize": 11, "legend.fontsize": 9}

#: Colour scale floor, as a fraction of the largest C_eq drawn (values below share one colour).
COLOUR_FLOOR = 1e-3

GRID_POINTS = 80


def save_figure(figure: Figure, stem: str | Path) -> list[Path]:
    """Save ``figure`` as ``<stem>.png`` (150 dpi) and ``<stem>.pdf``; return the two paths.

    Both files are cropped to the figure's tight bounding box, padded by
    ``savefig.pad_inches``, as ``bbox_inches="tight"`` crops them. The layout engine
    (constrained layout) runs once and the box is measured once, for both files: saved one
    after the other with ``"tight"``, each save laid the figure out and measured it again.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".pdf")]
    engine = figure.get_layout_engine()
    canvas = FigureCanvasAgg(figure)
    figure.draw_without_rendering()  # lays the figure out
    box = figure.get_tightbbox(canvas.get_renderer()).padded(rcParams["savefig.pad_inches"])
    with rc_context({"figure.autolayout": False, "figure.constrained_layout.use": False}):
        figure.set_layout_engine(None)  # no engine: each save renders this layout, no pre-draw
    try:
        for path in paths:
            figure.savefig(path, dpi=150, bbox_inches=box)
    finally:
        figure.set_layout_engine(engine)
    return paths


def frequency_ticks(ax, lo: float, hi: float) -> None:
    """Plain-number ticks (1-2-5 series) on a log frequency axis."""
    decades = 10.0 ** np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)
    ticks = [v for d in decades for v in (d, 2 * d, 5 * d) if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)]
    if len(ticks) < 2:
        ticks = [lo, hi]
    ax.set_xticks(ticks, labels=[f"{v:g}" for v in ticks])
    ax.set_xticks([], minor=True)
