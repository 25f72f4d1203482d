"""Stability at the corners of the grid, in the compiled DEM: the LIGGGHTS corner checks
(tests/liggghts/test_corners.py) on records of :func:`pidpipe.dem.case.run_dem_case`.

The same eight corners (50 / 1000 Hz x 1 / 10 g x 25 / 90 % fill), the same packings (LIGGGHTS'
pour, hence the engine mark), the default timestep and half of it: no sphere leaves the cell,
the dissipation is not negative beyond its uncertainty, the transient is detected on the
series, and C_eq agrees between the two timesteps or the case is flagged. The DEM has no
timestep warning of its own; its check is that dt stays below the configured fraction.
"""

from __future__ import annotations

import pytest

from pidpipe.dem.case import run_dem_case
from tests.liggghts.test_corners import (  # noqa: F401  (the checks, collected here too)
    shake_corners,
    test_ceq_converges_when_the_timestep_is_halved_or_the_case_is_flagged,
    test_dissipation_is_not_negative_beyond_its_uncertainty,
    test_no_sphere_leaves_the_cell,
    test_the_impacting_corners_are_sound_without_flags,
    test_the_transient_is_detected_on_the_series,
    test_timestep_check_passes,
)

pytestmark = pytest.mark.engine


@pytest.fixture(scope="module")
def corner_records(tmp_path_factory):
    """Records of every corner at dt and dt/2 from the compiled DEM."""
    records = shake_corners(tmp_path_factory, run_dem_case)
    assert all(r.solver == "numba-dem" for pair in records.values() for r in pair)
    return records
