"""Shared scenes for the NumPy DEM tests: SPEC.md's acrylic spheres in an aluminium cell."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pidpipe.cell.geometry import HexCell
from pidpipe.dem import Material, make_scene

DATA = Path(__file__).parent / "data"
ACRYLIC = Material(youngs_modulus_pa=2.84e9, poisson_ratio=0.402, density_kg_m3=1180.0,
                   radius_m=1.25e-3)
ALUMINIUM = Material(youngs_modulus_pa=70e9, poisson_ratio=0.33)
CELL = HexCell(4.76e-3, 25.4e-3)


def spec_scene(cell: HexCell = CELL, **overrides):
    """The reference scene (acrylic in aluminium, SPEC.md's pairs); keywords override."""
    params = dict(pp_friction=0.096, pp_restitution=0.70, pw_friction=0.14, pw_restitution=0.70,
                  freq_hz=500.0, accel_g=5.0, timestep_rayleigh_fraction=0.2)
    params.update(overrides)
    return make_scene(cell, ACRYLIC, ALUMINIUM, **params)


@pytest.fixture(scope="session")
def settled_11() -> np.ndarray:
    """11 acrylic spheres settled in the still cell (tests/dem/data/make_settled_packing.py)."""
    return np.loadtxt(DATA / "settled_11.csv", delimiter=",")
