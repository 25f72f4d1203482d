"""Pouring seeded packings in the compiled DEM: the LIGGGHTS pour's protocol, a few times cheaper.

The protocol is :mod:`pidpipe.cell.pour_protocol`'s, step for step as
:func:`pidpipe.liggghts.pour.pour` runs it (the same start from the seed, the same timestep and
step counts, the same tapping, settled-speed criterion and further settling), integrated by the
compiled kernel (:mod:`pidpipe.dem.run`) with the same contact law. The open pouring cell is a
taller :class:`~pidpipe.cell.geometry.HexCell` of the same hexagon whose floor is the cell's
floor and whose lid is at the top of LIGGGHTS' open side walls (4 radii above the highest start),
where no sphere reaches: a tap at 10 g and 100 Hz throws a sphere about 1.2 mm
((a/omega)^2 / 2g), less than half a radius. The kernel's frame has the tall cell's centre at
the origin; positions are shifted into it and back, by the same amount.

The two engines integrate the same protocol with different arithmetic, so a DEM packing is not
LIGGGHTS' packing of the same seed (a pour is chaotic: the sphere positions differ after a few
collisions); its bulk measures are what agree (tests/dem/test_pour.py). Each engine's pour is
reproducible from its seed, and each packing names the engine that poured it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from pidpipe.cell.geometry import HexCell
from pidpipe.cell.packing import MAX_FURTHER_SETTLING, SETTLED_SPEED_M_S, Packing
from pidpipe.cell.pour_protocol import TAP_ACCEL_G, TAP_FREQ_HZ, PourPlan, plan_pour, settled_packing
from pidpipe.config.settings import PourSettings
from pidpipe.dem import compiled
from pidpipe.dem.from_scene import dem_scene
from pidpipe.dem.run import advance, start
from pidpipe.dem.scene import Scene
from pidpipe.dem.state import State

ENGINE_NAME = "dem"
"""The value of ``fidelity.pour_engine`` that selects this pour, recorded in its packings."""


def pour(settings: PourSettings, fill_pct: float, replicate: int,
         workdir: str | Path | None = None) -> Packing:
    """Pour the spheres of a fill level into the cell in the compiled DEM; the settled packing.

    Parameters
    ----------
    settings : PourSettings
        The cell, materials, fidelity, fill definition and pouring settings.
    fill_pct : float
        Fill fraction, percent.
    replicate : int
        Replicate index; the packing seed is ``fidelity.seed + replicate``.
    workdir : path, optional
        Unused (the DEM writes no files); accepted so that both engines are called alike.

    Returns
    -------
    Packing
        ``pour_engine`` ``dem``; ``settle_time_s`` as the LIGGGHTS pour's (the configured
        settle time in whole steps, times the settling periods it took).
    """
    return pour_replicates(settings, fill_pct, [replicate])[0]


def pour_replicates(settings: PourSettings, fill_pct: float, replicates) -> list[Packing]:
    """The packings of several replicates of one fill, each exactly as :func:`pour` pours it.

    Replicates whose open pouring cell is the same (the same top of the side walls: at a low
    fill every seed's highest start is more than 4 radii below the lid) are poured as one batch
    of cells in each kernel call; the others one by one (the kernel's walls are shared by the
    cells of a batch, and the open cell's height, so the frame, depends on the seed). The cells
    of a batch are independent in the kernel (cell by cell, the same arithmetic as alone) and
    each keeps its own settle check: a cell settled after k settling periods is taken then,
    while the others go on, so every packing is bit for bit the one :func:`pour` gives alone
    (tests/dem/test_pour.py).

    Parameters
    ----------
    settings : PourSettings
    fill_pct : float
        Fill fraction, percent.
    replicates : sequence of int
        Replicate indices (seeds ``fidelity.seed`` + replicate).

    Returns
    -------
    list of Packing
        In the order of ``replicates``.
    """
    plans = [plan_pour(settings, fill_pct, int(k)) for k in replicates]
    groups: dict[float, list[int]] = {}
    for i, plan in enumerate(plans):
        groups.setdefault(plan.top_z_m, []).append(i)
    packings: list[Packing | None] = [None] * len(plans)
    for members in groups.values():
        for i, packing in zip(members, _pour_batch([plans[i] for i in members])):
            packings[i] = packing
    return packings


def _pour_batch(plans: list[PourPlan]) -> list[Packing]:
    """Pour plans that share the open cell (the same ``top_z_m``) as one batch of cells."""
    first = plans[0]
    still, tapping, shift = pour_scenes(first)
    scene, state, ws = start(still, np.stack([plan.start_m + shift for plan in plans]))
    tapping = dataclasses.replace(tapping, accel_g=np.repeat(tapping.accel_g, state.n_batch))
    advance(scene, state, ws, first.settle_steps)
    _tap(tapping, scene, state, ws, first.tap_steps)
    advance(scene, state, ws, first.settle_steps)
    chunks = 1
    settled: dict[int, Packing] = {}
    while True:
        speeds = _max_speeds(state)
        for b in range(state.n_batch):
            if b not in settled and (speeds[b] <= SETTLED_SPEED_M_S or chunks > MAX_FURTHER_SETTLING):
                settled[b] = settled_packing(plans[b], state.x[:, b, :].T - shift,
                                             state.v[:, b, :].T, chunks, ENGINE_NAME)
        if len(settled) == state.n_batch:
            return [settled[b] for b in range(state.n_batch)]
        advance(scene, state, ws, first.settle_steps)
        chunks += 1


def pour_scenes(plan: PourPlan) -> tuple[Scene, Scene, np.ndarray]:
    """The pour's DEM scenes in the tall open cell: still (0 g) and tapping, and the frame shift.

    Returns
    -------
    still, tapping : Scene
        The same scene (timestep and laws of the pour, the tall cell) at 0 g and at
        :data:`~pidpipe.cell.pour_protocol.TAP_ACCEL_G`, both at the tapping frequency.
    shift_m : ndarray, shape (3,)
        What to add to a cell-frame position to get its tall-cell-frame position, m.
    """
    cell = plan.scene.cell
    tall = HexCell(cell.inscribed_diameter_m, plan.top_z_m - cell.floor_z_m)
    tapping = dataclasses.replace(dem_scene(plan.scene, TAP_FREQ_HZ, TAP_ACCEL_G), cell=tall)
    if tapping.timestep_s != plan.timestep.timestep_s:
        raise AssertionError("the DEM pour's timestep differs from the protocol's")
    still = dataclasses.replace(tapping, accel_g=np.zeros_like(tapping.accel_g))
    shift = np.array([0.0, 0.0, tall.floor_z_m - cell.floor_z_m])
    return still, tapping, shift


def _tap(tapping: Scene, still: Scene, state: State, ws: compiled.KernelWorkspace,
         steps: int) -> None:
    """Tap for ``steps`` steps (whole cycles), the cell's motion starting at rest (t = 0 at its
    start, as LIGGGHTS' ``fix move/mesh`` defined there), then stop it."""
    compiled.set_base_motion(ws, tapping)
    state.step = 0
    advance(tapping, state, ws, steps)
    compiled.set_base_motion(ws, still)


def _max_speeds(state: State) -> np.ndarray:
    """Largest sphere speed of each cell of the batch, m/s; shape (n_batch,)."""
    return np.linalg.norm(state.v, axis=0).max(axis=1)
