"""The validation stage's step: chosen cases in LIGGGHTS and in the in-repo DEM, compared.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pidpipe.cases import CaseSpec
from pidpipe.files import write_atomic

logger = logging.getLogger("pidpipe.campaign")


def validate_against_dem(config: dict, cases: list[dict], packing_paths: list[str],
                         table_path: str, plot_path: str, workdir: str) -> None:
    """Run chosen cases in LIGGGHTS and in the NumPy DEM; write the comparison table and plot.

    Parameters
    ----------
    config : dict
        The case stage's config (:func:`stage_config`).
    cases : list of dict
        ``{"freq_hz", "accel_g", "fill_pct"}`` each (``validation.cases``).
    packing_paths : list of path
        The replicate-0 packings of the cases' fills.
    table_path, plot_path : path
        The comparison CSV and PNG.
    workdir : path
        Scratch folder for both solvers.
    """
    import shutil

    from pidpipe.cell.packing import load_packing
    from pidpipe.studies.validation import run_validation

    specs = [CaseSpec(float(c["freq_hz"]), float(c["accel_g"]), float(c["fill_pct"])) for c in cases]
    packings = {Path(path).stem: load_packing(path) for path in packing_paths}
    table = run_validation(config, specs, packings, workdir)
    write_atomic(table_path, lambda tmp: table.to_csv(tmp, index=False))
    shutil.copyfile(Path(workdir) / "validation.png", plot_path)
    logger.info("validation: %d of %d cases agree within 2 combined standard errors",
                int(table["agree"].sum()), len(table))
