"""The ``pidpipe`` command.

``pidpipe case --freq-hz 500 --accel-g 5 --fill-pct 50`` runs one case (pour, tap, shake) and
prints C_eq with its standard error and the fidelity that produced it (``--engine dem`` shakes
it in the compiled in-repo DEM instead of LIGGGHTS, on the same pour, by ``fidelity.pour_engine``); ``--record`` writes the
full machine-readable record. ``pidpipe check-config`` validates a config and prints the grid.
``pidpipe optimise [--table FILE]`` runs the optimisation stage alone on the campaign's C_eq
table or any table with the four required columns, and prints the designs.
``pidpipe refine [--table FILE] [--output-dir DIR]`` runs (or resumes) the design-driven
refinement loop on the config's engine and prints each round and what stopped it.
User errors print one line and exit 2, never a traceback.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
import sys
from pathlib import Path

from pidpipe.errors import PidpipeError

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pidpipe", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", default="config.yaml", type=Path,
                        help="config file (default: config.yaml)")
    commands = parser.add_subparsers(dest="command", required=True)

    case = commands.add_parser("case", help="run one case and print C_eq")
    case.add_argument("--freq-hz", type=float, required=True, help="excitation frequency, Hz")
    case.add_argument("--accel-g", type=float, required=True, help="acceleration amplitude, g")
    case.add_argument("--fill-pct", type=float, required=True, help="fill fraction, percent")
    case.add_argument("--replicate", type=int, default=0, help="packing replicate (seed offset)")
    case.add_argument("--workdir", type=Path, default=Path("work/cli"),
                      help="folder for decks and LIGGGHTS output (default: work/cli)")
    case.add_argument("--record", type=Path, help="write the case record (JSON) here")
    case.add_argument("--engine", choices=("liggghts", "dem"),
                      help="solver that shakes the case (default: the config's engine)")
    case.add_argument("--pilot-only", action="store_true",
                      help="run the pilot only (cells_per_run x measured_cycles), not on to the "
                           "config's fidelity.target_relative_sem")
    case.add_argument("--movie", action="store_true",
                      help="also write a ParaView movie of the last cycles (VTK series, movie.pvd; "
                           "frames and cycles from the config's inspection section)")
    case.add_argument("--movie-dir", type=Path,
                      help="folder of the movie (default: <workdir>/<case id>/movie)")

    commands.add_parser("check-config", help="validate the config and print the campaign")

    optimise = commands.add_parser(
        "optimise", help="optimise the designs on a C_eq table and print them",
        description="Fit the configured surrogate to a C_eq table (columns freq_hz, accel_g, "
                    "fill_pct, ceq_coupon_ns_m; ceq_coupon_sem_ns_m for intervals) and print the "
                    "peak, band_mean and worst_case design of every environment of the config.")
    _add_table_argument(optimise)
    optimise.add_argument("--config", type=Path, default=argparse.SUPPRESS,
                          help="config file (default: config.yaml)")
    optimise.add_argument("--draws", type=int,
                          help="bootstrap draws (default: optimisation.bootstrap.draws; 0: none)")
    optimise.add_argument("--output", type=Path,
                          help="also write the designs as CSV here (and <stem>.json, the full results)")

    damper = commands.add_parser(
        "damper", help="print the damper's effective mass and C_eq at one point",
        description="Read the campaign's C_eq and m_eff surrogates (results/surrogate.json, "
                    "results/surrogate_m_eff.json) and print the effective mass m_eff and the "
                    "equivalent dashpot C_eq that --cells filled cells add to a structure, with "
                    "their standard uncertainties, and the impedance Z = C_eq + i omega m_eff "
                    "(the cells' force on the structure is -Z times its velocity).")
    damper.add_argument("--freq-hz", type=float, required=True, help="frequency, Hz")
    damper.add_argument("--accel-g", type=float, required=True,
                        help="the cells' acceleration amplitude, g")
    damper.add_argument("--fill-pct", type=float, required=True, help="fill fraction, percent")
    damper.add_argument("--cells", type=int, default=1, help="filled cells (default: 1)")
    damper.add_argument("--results", type=Path, default=Path("results"),
                        help="folder of the surrogates (default: results)")
    damper.add_argument("--config", type=Path, default=argparse.SUPPRESS,
                        help="config file, for geometry.coupon_n_cells (default: config.yaml)")
    panel = commands.add_parser(
        "panel", help="the panel's modes and where on them to put the particles",
        description="Fit the configured surrogate to a C_eq table and run the modal stage: the "
                    "config's plate (panel), its modes, and on each mode in an environment's band "
                    "the source-style and the optimised layouts of the particles, with their added "
                    "loss factors. Writes modes.csv, layout.csv, designs.csv, response.csv and "
                    "panel.png into --output-dir.")
    _add_table_argument(panel)
    panel.add_argument("--config", type=Path, default=argparse.SUPPRESS,
                       help="config file (default: config.yaml)")
    panel.add_argument("--output-dir", type=Path, default=Path("results/panel"),
                       help="folder of the outputs (default: results/panel)")
    panel.add_argument("--m-eff-surrogate", type=Path,
                       help="m_eff surrogate (JSON, e.g. results/surrogate_m_eff.json) whose "
                            "effective mass the modal mass takes; default: fitted to the table "
                            "when it has m_eff_cell_kg, else the bed's mass")
    refine = commands.add_parser(
        "refine", help="run or resume the design-driven refinement loop on the config's engine",
        description="From a C_eq table, in rounds: fit the GP surrogate, optimise the designs, "
                    "verify them with the config's engine, and run the cases that most reduce "
                    "the designs' uncertainty, until every design verifies with its 95 % "
                    "interval within refine.interval_fraction, or refine.max_cpu_s of planned "
                    "engine CPU is spent, or refine.max_rounds have run (pidpipe.refine). "
                    "Resumes from the table it wrote in <output-dir>/state. Prints each round "
                    "and what stopped the loop; writes rounds.csv, summary.json and "
                    "convergence.png in --output-dir, the engine's files in <output-dir>/work, "
                    "and the table the designs rest on beside the output folder "
                    "(ceq_table_refined.csv), as snakemake refine does.")
    refine.add_argument("--table", type=Path, default=Path("results/ceq_table.csv"),
                        help="the grid's C_eq table (CSV), read when --output-dir has no table of "
                             "the loop's (default: results/ceq_table.csv)")
    refine.add_argument("--config", type=Path, default=argparse.SUPPRESS,
                        help="config file (default: config.yaml)")
    refine.add_argument("--output-dir", type=Path, default=Path("results/refine"),
                        help="folder of the loop's outputs (default: results/refine)")
    refine.add_argument("--cores", type=int, default=1,
                        help="cases of a round run this many at a time (default: 1)")
    return parser


def _check_case_arguments(args: argparse.Namespace, config: dict) -> None:
    from pidpipe.config import validate_config

    trial = dict(config)
    trial["grid"] = {"freq_hz": [args.freq_hz], "accel_g": [args.accel_g], "fill_pct": [args.fill_pct]}
    try:
        validate_config(trial)
    except PidpipeError as exc:
        raise PidpipeError(str(exc).replace("config key grid.freq_hz[0]", "--freq-hz")
                           .replace("config key grid.accel_g[0]", "--accel-g")
                           .replace("config key grid.fill_pct[0]", "--fill-pct")) from None
    if args.replicate < 0:
        raise PidpipeError(f"--replicate {args.replicate} is not allowed: it must be >= 0")


def run_case_command(args: argparse.Namespace) -> int:
    """Pour, check and shake one case; print the result."""
    from pidpipe.cases import CaseSpec
    from pidpipe.cell.packing import check_packing
    from pidpipe.config import load_config
    from pidpipe.config.settings import PourSettings, ShakeSettings
    from pidpipe.dem.pouring import pour_with_engine
    from pidpipe.steps.cases import measure_case

    config = load_config(args.config)
    if args.engine:
        config = {**config, "engine": args.engine}
    _check_case_arguments(args, config)
    pouring, shaking = PourSettings.from_config(config), ShakeSettings.from_config(config)
    if args.pilot_only:
        shaking = replace(shaking, sampling=replace(shaking.sampling, target_relative_sem=None))
    case = CaseSpec(args.freq_hz, args.accel_g, args.fill_pct, args.replicate)
    cells = shaking.sampling.cells_per_run
    replicates = range(case.replicate * cells, (case.replicate + 1) * cells)
    print(f"pidpipe: {case.case_id}: pouring {cells} packing(s) with {pouring.pouring.engine} ...",
          file=sys.stderr, flush=True)
    packings = [pour_with_engine(pouring, case.fill_pct, k, args.workdir / ("pour" if cells == 1 else f"pour{k}"))
                for k in replicates]
    for packing in packings:
        check_packing(packing, case.case_id)
    cycles = shaking.sampling.transient_cycles_at(case.freq_hz) + shaking.sampling.measured_cycles
    target = shaking.sampling.target_relative_sem
    print(f"pidpipe: {case.case_id}: shaking {cells} cell(s) of {packings[0].n_spheres} spheres "
          f"for {cycles} cycles in {shaking.engine}"
          + (f", then on until the SEM is {100 * target:g} % of C_eq (further packings poured "
             f"into {args.workdir / 'pool'})" if target else "") + " ...", file=sys.stderr, flush=True)
    movie, movie_dir = None, None
    if args.movie:
        from pidpipe.config.sections import Inspection

        if shaking.engine != "liggghts":
            raise PidpipeError("--movie is written from LIGGGHTS' dumps: it needs --engine liggghts")
        movie = Inspection.from_config(config).movie
        movie_dir = args.movie_dir or args.workdir / case.case_id / "movie"
    record = measure_case(shaking, case, packings, args.workdir / case.case_id, pouring,
                          args.workdir / "pool", movie=movie, movie_dir=movie_dir)
    if args.record:
        record.write(args.record)
    print(format_result(record))
    if movie is not None:
        print(f"  movie           : {record.movie['frames']} frames over the last "
              f"{record.movie['cycles']} cycles in {movie_dir / 'movie.pvd'} (open it in ParaView; "
              "Glyph the spheres by radius_m)")
    return 0


def format_result(record) -> str:
    """A few readable lines of a :class:`~pidpipe.measurement.case_record.CaseRecord`: C_eq with
    its standard error, the checks and the fidelity."""
    fid = record.fidelity
    lines = [
        f"case {record.case_id}: {record.n_spheres} spheres, status {record.status}"
        + (f" ({', '.join(record.flags)})" if record.flags else ""),
        f"  C_eq per cell   = {record.ceq_cell_ns_m:.4g} +- {record.ceq_cell_sem_ns_m:.2g} N s/m",
        f"  C_eq coupon     = {record.ceq_coupon_ns_m:.4g} +- {record.ceq_coupon_sem_ns_m:.2g} N s/m",
        f"  E_d per cycle   = {record.ed_cycle_mean_j:.4g} +- {record.ed_cycle_sem_j:.2g} J "
        f"(cycle-to-cycle std {record.ed_cycle_std_j:.2g} J, lag-1 autocorrelation "
        f"{record.ed_lag1_autocorrelation:.2f})",
        f"  steady state    : transient {fid.transient_cycles} cycles (configured "
        f"{fid['transient_cycles_configured']}, MSER {record.detected_transient_cycles}); "
        f"stored-energy drift {100 * record.energy_drift_fraction:.1f} % of the dissipation; "
        f"halves p = {record.halves_p_value:.2g}; regime {record.regime}"
        + (f" (cells: {_regime_split(record.motion['cell_regimes'])})" if record.motion else ""),
        f"  fidelity        : dt = {fid.timestep_s:.3g} s ({fid['rayleigh_fraction']:.3f} Rayleigh times), "
        f"{fid.transient_cycles} transient + {record.n_cycles} measured cycles, "
        f"E scale {fid['youngs_modulus_scale']:g}, seed {fid.seed}",
        f"  engine          : {record.solver} ({record.engine.version.split(',')[0]}), "
        f"{record.engine.wall_time_s:.1f} s; total {record.wall_time_s:.1f} s",
    ]
    target = record.target
    if target:
        lines.insert(2, f"  target          : SEM <= {100 * target['relative_sem']:g} % of C_eq "
                        f"{'reached' if target['reached'] else 'NOT reached (a cap stopped it)'} with "
                        f"{target['cells']} cells x {target['measured_cycles']} measured cycles in "
                        f"{len(target['runs'])} run(s), engine CPU {target['cpu_time_s']:.1f} s")
    if record.cells:
        lines.insert(3, f"  {len(record.cells)} cells         : SEM per cell from the cycles "
                        f"{record.ceq_cell_cycle_sem_ns_m:.2g}, from the spread between cells "
                        f"{record.ceq_cell_between_cells_sem_ns_m:.2g} N s/m (one two-level "
                        f"estimate of both is reported); seeds {', '.join(str(s) for s in fid.seeds)}")
    return "\n".join(lines)


def _regime_split(cell_regimes: list[str]) -> str:
    """How many cells are in each regime, e.g. ``5 bouncing_bed, 2 irregular``."""
    return ", ".join(f"{cell_regimes.count(name)} {name}" for name in dict.fromkeys(cell_regimes))


def check_config_command(args: argparse.Namespace) -> int:
    """Validate the config and print what the campaign will run."""
    from pidpipe.cases import grid_cases
    from pidpipe.config import load_config
    from pidpipe.config.schema import check_environments_in_reach
    from pidpipe.config.derived import poured_fill
    from pidpipe.config.sections import Settings

    config = load_config(args.config)
    check_environments_in_reach(config)
    settings = Settings.from_config(config)
    grid, fill, budget = settings.grid, settings.fill, settings.budget
    print(f"{args.config}: valid")
    print(f"  {len(grid_cases(config))} cases: f = {list(grid.freq_hz)} Hz x G = {list(grid.accel_g)} g x "
          f"r = {list(grid.fill_pct)} %")
    print("  spheres per cell: " + ", ".join(
        f"{r:g} % -> {fill.spheres(r)} ({poured_fill(r, fill.full_cell_spheres)[0]:g} %)"
        for r in grid.fill_pct)
          + f" (full cell = {fill.full_cell_spheres}, fill.definition = {fill.definition}; the "
          f"table and the surrogate place each case at the fill in brackets, the one its cells hold)")
    sampling = settings.sampling
    print(f"  pilots: {sampling.cells_per_run} cells x {sampling.measured_cycles} measured cycles"
          + _short_pilots(config))
    print(f"  particle budget: {budget.n_spheres} spheres for a panel of {budget.max_cells} "
          f"cells; environments: "
          + "; ".join(env.name for env in settings.environments))
    return 0


def _short_pilots(config: dict) -> str:
    """``; 12 at the 11 (f, G) points no band reads: ...`` (empty without short pilots)."""
    from pidpipe.config.pilots import pilot_measured_cycles, short_pilot_points

    points = short_pilot_points(config)
    if not points:
        return ""
    cycles = pilot_measured_cycles(config, *points[0])
    listed = ", ".join(f"{f:g} Hz/{g:g} g" for f, g in points)
    return (f"; {cycles} at the {len(points)} (f, G) point(s) whose levels bracket no "
            f"environment's band: {listed}")


def _add_table_argument(parser: argparse.ArgumentParser) -> None:
    """``--table``: the C_eq table a command fits its surrogate to (:func:`_table_surrogate`)."""
    parser.add_argument("--table", type=Path,
                        help="C_eq table (CSV); default: optimisation.external_ceq_table, else "
                             "results/ceq_table.csv")


def _table_surrogate(table: Path | None, settings):
    """The configured surrogate (``surrogate.method``, ``allow_holes``) fitted to ``table``, or to
    ``optimisation.external_ceq_table``, else ``results/ceq_table.csv``."""
    from pidpipe.design.ceq_table import read_ceq_table
    from pidpipe.design.surrogate import fit_surrogate

    path = table or Path(settings.optimisation.external_ceq_table or "results/ceq_table.csv")
    return fit_surrogate(read_ceq_table(path), method=settings.surrogate.method, source=str(path),
                         allow_holes=settings.surrogate.allow_holes)


def optimise_command(args: argparse.Namespace) -> int:
    """Fit the surrogate to a C_eq table, optimise every design, print them."""
    from pidpipe.config import load_config
    from pidpipe.design.designs import (
        format_designs,
        write_results_csv,
        write_results_json,
    )
    from pidpipe.config.sections import Settings
    from pidpipe.design.optimum import optimise_panel
    from pidpipe.files import write_atomic
    from pidpipe.steps.design import search_settings

    settings = Settings.from_config(load_config(args.config))
    if not settings.environments:
        raise PidpipeError(f"{args.config}: no environments to optimise for (config key environments)")
    optimisation = settings.optimisation
    surrogate = _table_surrogate(args.table, settings)
    bootstrap = optimisation.bootstrap
    if args.draws is not None:
        if args.draws < 0:
            raise PidpipeError(f"--draws {args.draws} is not allowed: it must be >= 0")
        bootstrap = replace(bootstrap, draws=args.draws)
    print(f"pidpipe: {surrogate.describe()}; {bootstrap.draws} bootstrap draws ...",
          file=sys.stderr, flush=True)
    optimum = optimise_panel(surrogate, list(settings.environments), settings.budget,
                             search_settings(optimisation.as_params()), bootstrap)
    print(format_designs(optimum.results))
    if optimum.note:
        print(f"note: {optimum.note}")
    if args.output:
        write_atomic(args.output, lambda tmp: write_results_csv(optimum.results, tmp))
        write_atomic(args.output.with_suffix(".json"),
                     lambda tmp: write_results_json(optimum.results, tmp))
    return 0


def damper_command(args: argparse.Namespace) -> int:
    """Print m_eff and C_eq of --cells cells at one (f, Gamma, r), with their uncertainties."""
    import math

    from pidpipe.config import load_config
    from pidpipe.design.damper import Damper

    if args.cells < 1:
        raise PidpipeError(f"--cells {args.cells} is not allowed: it must be >= 1")
    from pidpipe.config.sections import Settings

    budget = Settings.from_config(load_config(args.config)).budget
    damper = Damper.from_results(args.results, budget.n_cells_coupon)
    values = damper.values(args.freq_hz, args.accel_g, args.fill_pct, cells=args.cells)
    impedance = damper.impedance(args.freq_hz, args.accel_g, args.fill_pct, cells=args.cells)[0]

    def pm(value: float, sd: float, unit: str) -> str:
        return (f"{value:.4g} +- {sd:.2g} {unit}" if math.isfinite(sd)
                else f"{value:.4g} {unit} (the surrogate gives no uncertainty)")

    print(f"damper of {args.cells} cell(s) at f = {args.freq_hz:g} Hz, Gamma = {args.accel_g:g} g, "
          f"r = {args.fill_pct:g} %")
    print(f"  m_eff           = {pm(values.m_eff_kg[0], values.m_eff_sd_kg[0], 'kg')}")
    print(f"  C_eq            = {pm(values.ceq_ns_m[0], values.ceq_sd_ns_m[0], 'N s/m')}")
    print(f"  impedance Z     = {impedance.real:.4g} {impedance.imag:+.4g}i N s/m "
          "(force on the structure -Z V, V its velocity)")
    print(f"  surrogates      : {damper.describe()}")
    return 0


def panel_command(args: argparse.Namespace) -> int:
    """Fit the surrogate to a C_eq table and run the modal stage (pidpipe.panel)."""
    from pidpipe.config import load_config
    from pidpipe.config.sections import Settings
    from pidpipe.steps.panel import panel_study_from_config, write_panel_study

    config = load_config(args.config)
    settings = Settings.from_config(config)
    if not settings.environments:
        raise PidpipeError(f"{args.config}: no environments to design for (config key environments)")
    surrogate = _table_surrogate(args.table, settings)
    print(f"pidpipe: {surrogate.describe()}", file=sys.stderr, flush=True)
    m_eff = _panel_m_eff(args, settings, surrogate)
    study = panel_study_from_config(config, surrogate, m_eff)
    write_panel_study(study, args.output_dir)
    print(format_panel(study))
    print(f"wrote {args.output_dir}/modes.csv, layout.csv, designs.csv, response.csv, panel.png")
    return 0


def _panel_m_eff(args: argparse.Namespace, settings, surrogate):
    """The m_eff surrogate of ``pidpipe panel``: --m-eff-surrogate (checked against the table's
    C_eq surrogate), else the GP of the table's m_eff_cell_kg, else None (the bed's mass); the
    choice printed in one line."""
    from pidpipe.design.ceq_table import M_EFF_COLUMN, M_EFF_SEM_COLUMN, read_ceq_table
    from pidpipe.design.surrogate import fit_surrogate
    from pidpipe.steps.panel import panel_m_eff_surrogate

    if args.m_eff_surrogate is not None:
        if not args.m_eff_surrogate.is_file():
            raise PidpipeError(f"--m-eff-surrogate {args.m_eff_surrogate}: no such file")
        m_eff = panel_m_eff_surrogate(args.m_eff_surrogate, surrogate)
        print(f"pidpipe: modal mass with the m_eff of {args.m_eff_surrogate}", file=sys.stderr)
        return m_eff
    path = args.table or Path(settings.optimisation.external_ceq_table or "results/ceq_table.csv")
    table = read_ceq_table(path)
    if M_EFF_COLUMN not in table.columns or not table[M_EFF_COLUMN].notna().any():
        print(f"pidpipe: {path} has no {M_EFF_COLUMN}: the modal mass takes the bed's mass x "
              f"panel.effective_mass_fraction", file=sys.stderr)
        return None
    m_eff = fit_surrogate(table, method="gp", target="linear", source=str(path),
                          allow_holes=settings.surrogate.allow_holes, value_column=M_EFF_COLUMN,
                          sem_column=M_EFF_SEM_COLUMN)
    print(f"pidpipe: modal mass with the table's m_eff: {m_eff.describe()}", file=sys.stderr)
    return m_eff


def format_panel(study) -> str:
    """The modes in the bands and every layout's loss factor, as plain text."""
    lines = [f"panel {study.settings.length_m:g} m x {study.settings.width_m:g} m, "
             f"{len(study.centres)} cells, budget {study.settings.n_spheres} spheres; modes: "
             + ", ".join(f"({m.m},{m.n}) {m.freq_hz:.1f} Hz" for m in study.modes)]
    if study.designs.empty or "layout" not in study.designs:
        return "\n".join(lines + ["no mode lies in any environment's band"])
    if "modal_mass_source" in study.designs:
        lines += [f"  modal mass: {source}" for source in study.designs["modal_mass_source"].dropna().unique()]
    for _, row in study.designs.iterrows():
        if not isinstance(row.get("layout"), str):
            lines.append(f"  {row['environment']}: {row['note']}")
            continue
        lines.append(f"  {row['environment']}  mode ({row['mode_m']},{row['mode_n']})  "
                     f"{row['design']:<10} {row['layout']:<15} {row['n_cells']:>6} cells  "
                     f"{row['added_mass_kg']:.4f} kg  eta {row['eta']:.3e} "
                     f"[{row['eta_lo']:.3e}, {row['eta_hi']:.3e}]")
    return "\n".join(lines)


def refine_command(args: argparse.Namespace) -> int:
    """Run or resume the refinement loop on the config's engine; print every round and the stop."""
    from pidpipe.config import load_config
    from pidpipe.config.refine import RefineSettings
    from pidpipe.config.sections import Settings
    from pidpipe.refine.report import format_round
    from pidpipe.steps.refine import refine_campaign

    config = load_config(args.config)
    settings, refine = Settings.from_config(config), RefineSettings.from_config(config)
    state = args.output_dir / "state" / "ceq_table.csv"
    resuming = state.is_file()
    if not resuming and not args.table.is_file():
        raise PidpipeError(f"--table {args.table}: no such file (run the campaign first, or name "
                           "a C_eq table)")
    if args.cores < 1:
        raise PidpipeError(f"--cores {args.cores} is not allowed: it must be >= 1")
    start = f"resuming from {state}" if resuming else f"starting from {args.table}"
    print(f"pidpipe: refine on {config['engine']}, {start}; budget {refine.max_cpu_s:g} planned "
          f"CPU-s, {refine.cases_per_round} case(s) per round, at most {refine.max_rounds} "
          f"rounds; each design within +-{100 * refine.interval_fraction:g} % and "
          f"|z| <= {settings.verify.flag_z:g}", flush=True)
    outcome, engine = refine_campaign(config, args.table, args.output_dir,
                                      on_round=lambda record: print(format_round(record),
                                                                    flush=True),
                                      cores=args.cores)
    print(f"stopped: {outcome.stopped_by} after {len(outcome.rounds)} round(s) in this run; "
          f"the engine ran {len(engine.runs)} case(s) in it; planned engine CPU of the loop "
          f"{outcome.table['planned_cpu_s'].sum():.1f} s of {refine.max_cpu_s:g} s")
    spent = engine.measured
    print(f"measured in this run: shaking {spent['shake_cpu_s']:.1f} CPU-s, pours "
          f"{spent['pour_cpu_s']:.1f} CPU-s ({spent['pour_wall_s']:.1f} s wall; the plan charges "
          "every case its packings' pours, shared ones too)")
    for line in outcome.open:
        print(f"  open: {line}")
    print(f"wrote {args.output_dir}/rounds.csv, summary.json, convergence.png (the loop's table "
          f"in {args.output_dir}/state), and {args.output_dir.parent}/ceq_table_refined.csv")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    handlers = {"case": run_case_command, "check-config": check_config_command,
                "optimise": optimise_command, "damper": damper_command, "panel": panel_command,
                "refine": refine_command}
    try:
        return handlers[args.command](args)
    except PidpipeError as exc:
        print(f"pidpipe: error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("pidpipe: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
