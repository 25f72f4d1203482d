"""The refinement loop's rounds as plain text (printed by ``pidpipe refine``, logged by the
workflow's steps)."""

from __future__ import annotations


import math


def format_round(record) -> str:
    """A round of the refinement loop as plain text: what it added, its CPU, every design's
    interval and worst |z| (:class:`pidpipe.refine.loop.RoundRecord`)."""
    lines = [f"round {record.round}: {record.cases_added} new case(s), {record.cases_extended} "
             f"extended, {record.verify_cases} verifying; planned engine CPU "
             f"{record.engine_cpu_s:.1f} s (loop total {record.cumulative_cpu_s:.1f} s)"]
    for interval in record.intervals:
        name = f"{interval.environment}/{interval.kind}"
        z = record.worst_z.get(name, math.nan)
        lines.append(f"  {name:<34} r {interval.fill_pct:5.1f} %  {interval.n_cells:5.0f} cells  "
                     f"total C_eq {interval.total_ceq_ns_m:.4g} N s/m [{interval.lo:.4g}, "
                     f"{interval.hi:.4g}] (+-{100 * interval.half_width_fraction:.1f} %)  worst |z| "
                     + (f"{abs(z):.2f}" if math.isfinite(z) else "not verified"))
    return "\n".join(lines)
