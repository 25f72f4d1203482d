"""Draw the README's figure: one honeycomb cell with its spheres, and the pipeline's stages.

Usage (from the repository root)::

    python docs/figures/pipeline.py [docs/figures/pipeline.png]

The cell is the default campaign's (inscribed diameter 4.76 mm, height 25.4 mm, from
``pidpipe.cell.geometry.HexCell``); the spheres are the settled 11-sphere packing (50 % fill)
that the DEM tests use, ``tests/dem/data/settled_11.csv``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyArrowPatch, FancyBboxPatch, Polygon  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from pidpipe.cell.geometry import HexCell  # noqa: E402

RADIUS_M = 1.25e-3
STAGES = (
    ("pour", "spheres poured, tapped\nand settled in the cell\n(fill r: 5-19 spheres)"),
    ("shake", "base motion\nz = W(cos ωt - 1), a = G·g\nLIGGGHTS or compiled DEM"),
    ("measure", "E_d per cycle, steady state\nC_eq = E_d / (π ω W²)\n± SEM to a target"),
    ("surrogate", "C_eq(f, G, r) over the grid\nthin-plate RBF\nleave-one-out error"),
    ("design", "SLSQP: fill r and cells n_c\nunder the sphere budget,\nper environment"),
)


def draw(path: Path) -> None:
    """Write the figure to ``path`` (PNG, 150 dpi)."""
    cell = HexCell(4.76e-3, 25.4e-3)
    centres = np.loadtxt(REPO / "tests" / "dem" / "data" / "settled_11.csv", delimiter=",")
    mm = 1e3
    r_c = cell.circumradius_m * mm
    half_h = cell.height_m * mm / 2

    fig = plt.figure(figsize=(10, 4.2))
    side = fig.add_axes([0.02, 0.04, 0.17, 0.82])
    top = fig.add_axes([0.2, 0.5, 0.13, 0.36])
    flow = fig.add_axes([0.35, 0.02, 0.63, 0.96])

    # Side view (x, z): the walls at x = +-R (the hexagon's width across its vertices), the
    # face sheets at z = +-h/2, the spheres by their centres.
    side.add_patch(Polygon([(-r_c, -half_h), (r_c, -half_h), (r_c, half_h), (-r_c, half_h)],
                           closed=True, fill=False, lw=1.5, color="0.3"))
    for x, _, z in centres:
        side.add_patch(Circle((x * mm, z * mm), RADIUS_M * mm, color="tab:blue", alpha=0.8))
    side.add_patch(FancyArrowPatch((r_c + 1.2, -4), (r_c + 1.2, 4), arrowstyle="<->",
                                   mutation_scale=10, color="tab:red"))
    side.text(r_c + 1.7, 0, "W cos ωt", rotation=90, va="center", color="tab:red", fontsize=8)
    side.set_xlim(-r_c - 0.6, r_c + 3.2)
    side.set_ylim(-half_h - 0.8, half_h + 0.8)
    side.set_aspect("equal")
    side.set_title("one cell, side\n(25.4 mm high)", fontsize=9)
    side.axis("off")

    # Top view (x, y): the hexagon, vertices at (+-R, 0).
    angles = np.deg2rad(60.0 * np.arange(6))
    top.add_patch(Polygon(np.column_stack([r_c * np.cos(angles), r_c * np.sin(angles)]),
                          closed=True, fill=False, lw=1.5, color="0.3"))
    for x, y, _ in centres:
        top.add_patch(Circle((x * mm, y * mm), RADIUS_M * mm, color="tab:blue", alpha=0.35))
    top.set_xlim(-r_c - 0.3, r_c + 0.3)
    top.set_ylim(-r_c - 0.3, r_c + 0.3)
    top.set_aspect("equal")
    top.set_title("top (4.76 mm\nacross flats)", fontsize=9)
    top.axis("off")

    # The stages, left to right then down.
    flow.set_xlim(0, 10)
    flow.set_ylim(0, 10)
    flow.axis("off")
    spots = [(1.7, 7.4), (5.0, 7.4), (8.3, 7.4), (3.35, 3.0), (6.65, 3.0)]
    for (name, text), (x, y) in zip(STAGES, spots):
        flow.add_patch(FancyBboxPatch((x - 1.45, y - 1.3), 2.9, 2.6, boxstyle="round,pad=0.05",
                                      fc="0.95", ec="0.4"))
        flow.text(x, y + 1.0, name, ha="center", va="center", fontsize=10, weight="bold")
        flow.text(x, y - 0.3, text, ha="center", va="center", fontsize=7.5)
    for (x0, y0), (x1, y1) in zip(spots, spots[1:]):
        start, end = ((x0 + 1.5, y0), (x1 - 1.5, y1)) if y0 == y1 else ((x0 - 0.8, y0 - 1.4), (x1, y1 + 1.4))
        flow.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=12, color="0.3"))
    flow.text(5.0, 0.5, "one case per point of a grid f × G × r; each design then checked\n"
              "by DEM at its own fill (verify) and on a vibrating host (host)",
              ha="center", va="center", fontsize=8, style="italic")
    fig.savefig(path, dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    draw(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_suffix(".png"))
