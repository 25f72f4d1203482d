"""The phase-resolved figure of a case: one cycle of the bed's motion, averaged over the measured cycles.

Three panels over the phase of the base motion (0 = the wall at its top, z = W (cos 2 pi phi - 1)):
the wall position and the bed's centre of mass above the floor; the force of the floor on the
bed and of the bed on the lid; the dissipation rate. Lines are the mean over the measured
cycles of the run's mean cell, bands the cycle-to-cycle standard deviation (the spread, not the
error of the mean). The title gives the case, its regime and how it was computed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from pidpipe.figures.common import RC_PARAMS, save_figure
from pidpipe.measurement.case_record import CaseRecord


def _band(ax, phase, quantity: dict, scale: float, label: str, colour: str) -> None:
    """The mean (line) and mean +- std (band) of one profile quantity, times ``scale``."""
    mean = np.asarray(quantity["mean"], dtype=float) * scale
    std = np.nan_to_num(np.asarray(quantity["std"], dtype=float)) * scale
    ax.plot(phase, mean, color=colour, label=label, marker=".", markersize=4)
    ax.fill_between(phase, mean - std, mean + std, color=colour, alpha=0.25, linewidth=0)


def plot_phase_profile(record: CaseRecord, stem: str | Path | None = None) -> Figure:
    """The phase-resolved figure of one case record that sampled its motion.

    Parameters
    ----------
    record : CaseRecord
        A case record with ``motion`` (:func:`pidpipe.liggghts.shake.run_case`).
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure

    A record without a motion (a failed case, or one run with the sampling off) gives a figure
    that says so, so that one failed case does not stop the gallery.
    """
    import matplotlib as mpl

    motion = record.motion
    if not motion:
        with mpl.rc_context(RC_PARAMS):
            fig = Figure(figsize=(6.4, 2.0), layout="constrained")
            ax = fig.subplots()
            ax.set_axis_off()
            ax.text(0.5, 0.5, f"{record.case_id}: no phase profile\n(status "
                    f"{record.status}; the bed's motion was not sampled)",
                    ha="center", va="center", transform=ax.transAxes)
            if stem is not None:
                save_figure(fig, stem)
        return fig
    profile = motion["profile"]
    phase = np.asarray(profile["phase"], dtype=float)
    fid = record.fidelity
    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(6.4, 7.2), layout="constrained")
        top, middle, bottom = fig.subplots(3, 1, sharex=True)
        _band(top, phase, profile["centre_m"], 1e3, "bed centre of mass above the floor", "C0")
        top.set_ylabel("centre of mass (mm)")
        wall = top.twinx()
        _band(wall, phase, profile["wall_z_m"], 1e6, "wall position", "0.3")
        wall.set_ylabel("wall position z (µm)")
        handles = top.get_legend_handles_labels()[0] + wall.get_legend_handles_labels()[0]
        top.legend(handles, [h.get_label() for h in handles], loc="upper right", fontsize=8)
        _band(middle, phase, profile["floor_force_n"], 1e3, "floor on the bed", "C2")
        _band(middle, phase, profile["lid_force_n"], 1e3, "bed on the lid", "C3")
        middle.axhline(profile["bed_weight_n"] * 1e3, color="0.5", linestyle=":", linewidth=1,
                       label="bed weight")
        middle.set_ylabel("force (mN)")
        middle.legend(loc="upper right", fontsize=8)
        _band(bottom, phase, profile["dissipation_w"], 1e6, "dissipation rate (mean cell)", "C1")
        bottom.axhline(0.0, color="0.5", linewidth=0.8)
        bottom.set_ylabel("dissipation rate (µW)")
        bottom.set_xlabel("phase of the base motion (cycles; 0 = wall at its top)")
        bottom.set_xlim(0.0, 1.0)
        bottom.legend(loc="upper right", fontsize=8)
        cells = motion.get("cell_regimes", [])
        split = ", ".join(f"{cells.count(n)} {n.replace('_', ' ')}" for n in dict.fromkeys(cells))
        fig.suptitle(f"{record.case_id}: regime {record.regime.replace('_', ' ')} "
                     f"(cells: {split})\nmean ± std over {profile['n_cycles']} measured cycles, "
                     f"{len(cells)} cell(s); dt = {fid.timestep_s:.3g} s, "
                     f"{record.solver}", fontsize=10)
        if stem is not None:
            save_figure(fig, stem)
    return fig
