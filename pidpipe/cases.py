"""Cases of a campaign: one (frequency, acceleration, fill, replicate) each, with a stable id.

Case ids appear in file names and Snakemake wildcards, so numbers are written exactly and
always the same way: the shortest decimal that reads back as the same float, no exponent,
no trailing zeros (50.0 -> "50", 2.5 -> "2.5").
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass

import numpy as np

from pidpipe.errors import ConfigError

CASE_ID_PATTERN = r"f(?P<freq>[0-9.]+)Hz_G(?P<accel>[0-9.]+)_r(?P<fill>[0-9.]+)pct_rep(?P<replicate>[0-9]+)"
NUMBER_PATTERN = r"[0-9]+(\.[0-9]+)?"


def format_number(value: float) -> str:
    """Exact, stable text for a positive number in a file name ("50", "2.5", "0.001")."""
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"only finite non-negative numbers go into case ids, got {value!r}")
    return np.format_float_positional(value, trim="-", unique=True)


@dataclass(frozen=True)
class CaseSpec:
    """One simulated case.

    Parameters
    ----------
    freq_hz : float
        Excitation frequency, Hz.
    accel_g : float
        Base acceleration amplitude, in g.
    fill_pct : float
        Fill fraction, percent of a full cell.
    replicate : int
        Replicate index (0 for the first packing); replicate k uses packing seed + k.
    """

    freq_hz: float
    accel_g: float
    fill_pct: float
    replicate: int = 0

    @property
    def case_id(self) -> str:
        """Stable id, e.g. ``f500Hz_G5_r50pct_rep0``."""
        return (f"f{format_number(self.freq_hz)}Hz_G{format_number(self.accel_g)}"
                f"_r{format_number(self.fill_pct)}pct_rep{self.replicate}")

    @property
    def packing_id(self) -> str:
        """Id of the packing this case shakes (packings depend on fill and replicate only)."""
        return f"r{format_number(self.fill_pct)}pct_rep{self.replicate}"

    def packing_ids(self, cells_per_run: int = 1) -> list[str]:
        """Ids of the packings this case shakes, one per cell of its run.

        Replicate q of a case with k cells per run shakes packings q*k .. q*k + k - 1 of its fill,
        so that no two cells of a campaign's grid point share a packing; with k = 1 this is
        just :attr:`packing_id`.
        """
        first = self.replicate * cells_per_run
        return [f"r{format_number(self.fill_pct)}pct_rep{index}"
                for index in range(first, first + cells_per_run)]

    @classmethod
    def from_id(cls, case_id: str) -> "CaseSpec":
        """Parse a case id written by :attr:`case_id`."""
        match = re.fullmatch(CASE_ID_PATTERN, case_id)
        if match is None:
            raise ConfigError(f"{case_id!r} is not a case id (expected e.g. f500Hz_G5_r50pct_rep0)")
        return cls(float(match["freq"]), float(match["accel"]), float(match["fill"]),
                   int(match["replicate"]))


def grid_cases(config: dict, replicates: int = 1) -> list[CaseSpec]:
    """All cases of the config's grid, in a stable order (frequency, acceleration, fill, replicate)."""
    grid = config["grid"]
    return [CaseSpec(float(f), float(g), float(r), k)
            for f, g, r, k in itertools.product(sorted(grid["freq_hz"]), sorted(grid["accel_g"]),
                                                sorted(grid["fill_pct"]), range(replicates))]


REGIME_NO_LIFT_OFF = "no_lift_off"
REGIME_IMPACTING = "impacting"


def regime(accel_g: float) -> str:
    """The excitation regime: ``no_lift_off`` if the base acceleration does not exceed gravity.

    At G <= 1 a sphere resting on the floor is never pulled off it: the bed moves with the
    cell, and what dissipates is contact damping and micro-slip, small and hard to resolve.
    """
    return REGIME_NO_LIFT_OFF if accel_g <= 1.0 else REGIME_IMPACTING
