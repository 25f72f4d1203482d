"""Sequential allocation: the cheapest next run that brings a case's SEM to its target.

After a pilot of k0 cells x n0 measured cycles, the case's standard error is modelled by its two
variance components (:func:`pidpipe.measurement.cells.mean_of_cells`): the spread between
packings, sigma_b^2, which only more cells reduce, and the cells' long-run cycle noise tau^2
(a cell's squared SEM over n cycles is tau^2 / n), so that K cells of N cycles each give

    SEM^2(K, N) = (sigma_b^2 + tau^2 / (N - L)) / K,

with L the measured cycles that the steady-state test discards beyond the configured transient
(:attr:`Components.lost_cycles`: a run of N measured cycles keeps N - L of them when it finds
a longer transient).

Three kinds of step can follow (all cells of a case always have the same measured cycles):

- ``more_cells``: m new packings shaken for the current N cycles, in new runs;
- ``more_cycles``: the same K cells for N' > N cycles. An engine whose runs go on from where
  they ended (the compiled DEM) continues each run for N' - N cycles, and pays only those;
  otherwise (LIGGGHTS) the same runs are made again, longer (the same layout replays the
  shorter run cycle for cycle, so the longer run replaces it; its transient and first N cycles
  are paid again);
- ``both``: K + m cells of N' cycles, all in new runs (the old runs are replaced), or, for an
  engine that continues its runs and where that is cheaper, the K cells' runs continued and the
  m new ones shaken in new runs.

Every step's CPU time comes from a cost model of one run of k cells x n cycles (``run_cpu_s``,
transient included, e.g. :class:`pidpipe.measurement.cost_model.CostModel` bound to the case's
frequency and spheres), plus ``pour_cpu_s`` per new packing, and, for an engine that
continues its runs, ``continue_cpu_s(N')``: the CPU time of taking every current run on from N
to N' cycles; a run holds at most ``cells_per_run`` cells, more are split into several runs. For each total cell count K' the
fewest cycles N' that reach the target are the cheapest, so :func:`plan_next_step` scans K'
and takes the cheapest step within the caps; when no step reaches the target within them it
takes the cheapest step whose predicted SEM is within 2 % of the smallest that the caps
allow (:data:`NEAR_BEST`), if it cuts the SEM by at least 10 % (:data:`WORTHWHILE`; the case then ends with ``target_not_reached``). Everything here is pure: numbers in, a :class:`Step` out.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

PLAN_MARGIN = 1.2
"""Steps are planned for SEM^2 <= target^2 / PLAN_MARGIN: the components are estimates."""

WORTHWHILE = 0.9
"""A step that cannot reach the target is taken only if it brings the SEM below this fraction
of the present one (no CPU spent on a negligible gain)."""

NEAR_BEST = 1.02
"""Of the steps that cannot reach the target, the cheapest whose predicted SEM is within 2 % of
the smallest is taken (cycles that buy nothing against a packing spread are not run)."""


@dataclasses.dataclass(frozen=True)
class Components:
    """The variance components of a case's C_eq, estimated from the cells measured so far.

    Attributes
    ----------
    value : float
        C_eq of the mean cell, N s/m.
    packing_var : float
        sigma_b^2, (N s/m)^2.
    cycle_noise_var : float
        tau^2, (N s/m)^2 x cycles.
    lost_cycles : float
        L, measured cycles (as configured) that the cells do not keep: the steady-state test
        found a transient longer than the configured one and discarded them, cycles (>= 0).
    """

    value: float
    packing_var: float
    cycle_noise_var: float
    lost_cycles: float = 0.0

    def sem(self, cells: int, cycles: int) -> float:
        """Predicted SEM of the mean of ``cells`` cells of ``cycles`` measured cycles each, N s/m."""
        kept = max(cycles - self.lost_cycles, 1.0)
        return math.sqrt((self.packing_var + self.cycle_noise_var / kept) / cells)

    def cycles_for(self, cells: int, sem: float) -> float:
        """Fewest measured cycles for which ``cells`` cells reach ``sem`` (inf if no number does)."""
        room = cells * sem ** 2 - self.packing_var
        return self.cycle_noise_var / room + self.lost_cycles if room > 0.0 else math.inf


@dataclasses.dataclass(frozen=True)
class Limits:
    """The caps of one case.

    Attributes
    ----------
    max_cells : int
        Cells (packings) of the case, at most.
    max_cycles : int
        Measured cycles per cell, at most.
    max_cpu_s : float
        CPU time of all the case's runs (and the pours charged to it), at most, s.
    cells_per_run : int
        Cells one run can hold (:data:`pidpipe.cell.layout.MAX_CELLS`).
    """

    max_cells: int
    max_cycles: int
    max_cpu_s: float
    cells_per_run: int


@dataclasses.dataclass(frozen=True)
class Step:
    """One planned step.

    Attributes
    ----------
    kind : {"more_cells", "more_cycles", "both"}
    new_cells : int
        Packings added.
    run_cells : int
        Cells shaken in new runs, from their pour (the new ones only, or all of the case's when
        the old runs are replaced).
    cycles : int
        Measured cycles of the step's runs (the case's N afterwards).
    cpu_s : float
        Predicted CPU time of the step (runs + pours), s.
    predicted_sem : float
        The case's SEM after it, as planned, N s/m.
    reaches_target : bool
    continued_cells : int
        Cells whose runs go on to ``cycles`` (all the case's cells before the step when its
        runs are continued, else 0).
    """

    kind: str
    new_cells: int
    run_cells: int
    cycles: int
    cpu_s: float
    predicted_sem: float
    reaches_target: bool
    continued_cells: int = 0

    def as_record(self) -> dict:
        return dataclasses.asdict(self)


def runs_cpu_s(cells: int, cycles: int, run_cpu_s: Callable[[int, int], float],
               cells_per_run: int) -> float:
    """CPU time of shaking ``cells`` cells for ``cycles`` measured cycles, in as few runs as the
    per-run limit allows (cells spread evenly over the runs), s."""
    runs = math.ceil(cells / cells_per_run)
    base, extra = divmod(cells, runs)
    return sum(run_cpu_s(base + (1 if i < extra else 0), cycles) for i in range(runs))


def step_to(cells: int, cycles: int, new_cells: int, new_cycles: int, components: Components,
            target_sem: float, run_cpu_s: Callable[[int, int], float], pour_cpu_s: float,
            cells_per_run: int, continue_cpu_s: Callable[[int], float] | None = None) -> Step:
    """The step from ``cells`` x ``cycles`` to ``cells + new_cells`` x ``new_cycles``, with its
    cost; with ``continue_cpu_s`` (see :func:`plan_next_step`) more cycles continue the runs,
    or, for a ``both`` step, the cheaper of that and shaking all cells in new runs (one run of
    all cells can cost less than the old runs continued beside a run of the new ones: an
    engine's per-step cost that does not grow with the cells is paid once)."""
    sem = components.sem(cells + new_cells, new_cycles)
    if new_cycles == cycles:
        kind, run_cells = "more_cells", new_cells
    else:
        kind, run_cells = ("both", cells + new_cells) if new_cells else ("more_cycles", cells)
    cost = runs_cpu_s(run_cells, new_cycles, run_cpu_s, cells_per_run) + new_cells * pour_cpu_s
    step = Step(kind, new_cells, run_cells, new_cycles, cost, sem, sem <= target_sem)
    if continue_cpu_s is None or new_cycles == cycles:
        return step
    cost = continue_cpu_s(new_cycles) + new_cells * pour_cpu_s
    if new_cells:
        cost += runs_cpu_s(new_cells, new_cycles, run_cpu_s, cells_per_run)
    continued = Step(kind, new_cells, new_cells, new_cycles, cost, sem, sem <= target_sem, cells)
    return continued if continued.cpu_s <= step.cpu_s else step


def plan_next_step(components: Components, cells: int, cycles: int, spent_cpu_s: float,
                   target_sem: float, limits: Limits, run_cpu_s: Callable[[int, int], float],
                   pour_cpu_s: float, continue_cpu_s: Callable[[int], float] | None = None
                   ) -> Step | None:
    """The cheapest step that reaches the target within the caps, else the one that comes closest.

    Parameters
    ----------
    components : Components
        Estimated from the cells so far.
    cells, cycles : int
        Cells measured so far, and their measured cycles each.
    spent_cpu_s : float
        CPU time the case has used (the pilot and any steps), s.
    target_sem : float
        Target SEM, N s/m (the relative target times |C_eq|).
    limits : Limits
    run_cpu_s : callable
        ``run_cpu_s(k, n)``: CPU time of one run of k cells x n measured cycles, s.
    pour_cpu_s : float
        CPU time charged for each new packing, s (0 if already poured; a share of a pour when
        the packing is shared by several cases).
    continue_cpu_s : callable, optional
        ``continue_cpu_s(n)``: CPU time of taking every current run on from ``cycles`` to
        ``n`` measured cycles, s, for an engine whose runs go on from where they ended; None:
        more cycles make the runs again (they replay), at ``run_cpu_s`` of the longer runs.

    Returns
    -------
    Step or None
        None when the SEM is already at the target, or no step fits the caps and improves it.
    """
    if components.sem(cells, cycles) <= target_sem:
        return None
    plan_sem = target_sem / math.sqrt(PLAN_MARGIN)
    budget = limits.max_cpu_s - spent_cpu_s
    affordable = []
    for total in range(cells, limits.max_cells + 1):
        wanted = components.cycles_for(total, plan_sem)
        options = {cycles, min(limits.max_cycles, max(cycles, math.ceil(min(wanted, 1e12))))}
        for new_cycles in sorted(options):
            if total == cells and new_cycles == cycles:
                continue
            step = step_to(cells, cycles, total - cells, new_cycles, components, target_sem,
                           run_cpu_s, pour_cpu_s, limits.cells_per_run, continue_cpu_s)
            if step.cpu_s > budget:
                step = largest_affordable(cells, cycles, total - cells, new_cycles, budget,
                                          components, target_sem, run_cpu_s, pour_cpu_s,
                                          limits.cells_per_run, continue_cpu_s)
            if step is not None:
                affordable.append(step)
    reaching = [step for step in affordable if step.predicted_sem <= plan_sem * (1 + 1e-12)]
    if reaching:
        return min(reaching, key=lambda step: (step.cpu_s, step.predicted_sem))
    now = components.sem(cells, cycles)
    better = [step for step in affordable if step.predicted_sem <= WORTHWHILE * now]
    if not better:
        return None
    best = min(step.predicted_sem for step in better)
    return min((step for step in better if step.predicted_sem <= NEAR_BEST * best),
               key=lambda step: (step.cpu_s, step.predicted_sem))


def largest_affordable(cells: int, cycles: int, new_cells: int, max_new_cycles: int,
                       budget_s: float, components: Components, target_sem: float,
                       run_cpu_s: Callable[[int, int], float], pour_cpu_s: float,
                       cells_per_run: int, continue_cpu_s: Callable[[int], float] | None = None
                       ) -> Step | None:
    """The step adding ``new_cells`` with the most cycles (``cycles`` .. ``max_new_cycles``) that
    ``budget_s`` pays for; None if even ``cycles`` is too dear (or nothing would change)."""
    def step(n: int) -> Step:
        return step_to(cells, cycles, new_cells, n, components, target_sem, run_cpu_s,
                       pour_cpu_s, cells_per_run, continue_cpu_s)

    low = cycles if new_cells else cycles + 1
    if low > max_new_cycles or step(low).cpu_s > budget_s:
        return None
    high = max_new_cycles
    while low < high:   # the most cycles whose cost fits (cost grows with the cycles)
        middle = (low + high + 1) // 2
        if step(middle).cpu_s <= budget_s:
            low = middle
        else:
            high = middle - 1
    return step(low)
