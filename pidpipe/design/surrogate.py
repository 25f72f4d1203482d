"""Spline surrogates of the coupon's C_eq (N*s/m) over (f [Hz], G [g], r [%]).

Coordinates and target
----------------------
The interpolants work in ``u = (ln f, ln G, r)``. C_eq = E_d / (pi * omega * W^2) with
W = a/omega^2 grows like a power of f (roughly f^1 when the spheres impact every cycle), and the
reference grid is close to log-spaced in f (50 ... 1000 Hz), so ln f makes the f dependence
nearly linear. G enters through W^2 = (G g / omega^2)^2, so C_eq also behaves like a power of G
where E_d does, and ln G stretches the steep onset just above 1 g where the spheres start to
lift off (on the analytic test table this alone cut the off-grid error of every method by 2-10
times). r (25-90 %) stays linear.

The fitted value is, with ``target="log"`` (the default), ``y = ln(C + c0)`` with the offset
``c0 = log_offset_fraction * max(C)`` over the training rows. The log turns the steep power law
in f into a near-linear function and makes interpolation errors relative rather than absolute.
The offset is there because C_eq can be ~0 (at low G the spheres hardly lift off): ln(0) does
not exist, and ln of a value at the DEM noise level would put a deep, meaningless dip in the
surface. Values well above c0 are fitted in log; values below c0 (0.1 % of the largest by
default, below the DEM's statistical error) are fitted almost linearly. ``target="linear"``
fits C itself. Either way a prediction is clipped at 0 N*s/m (dissipation is not negative); the
clip only acts where an interpolant overshoots below zero, i.e. at the scale of c0 for "log".

Methods (:data:`METHODS`)
-------------------------
``tensor_linear``
    Multilinear interpolation on the complete regular grid (needs >= 2 levels per axis).
``tensor_spline``
    Tensor product of 1-D interpolating splines of degree min(3, n_levels - 1) per axis
    (not-a-knot cubic along f with 5 levels and r with 4, a parabola along G with 3, linear on
    a 2-level CI grid).
``rbf_thin_plate``
    Thin-plate-spline radial basis interpolant with a linear polynomial tail
    (``scipy.interpolate.RBFInterpolator``) on coordinates scaled to [0, 1] by the domain;
    works on scattered points, so it can fit a grid with holes when asked explicitly.

Domain and extrapolation policy
-------------------------------
The domain is the bounding box of the fitted rows, per variable. :meth:`Surrogate.predict`
refuses any query outside it with :class:`~pidpipe.errors.DomainError` (no extrapolation, no
silent clipping); a tolerance of 1e-9 of the axis span absorbs rounding only.

Rows that are not ``status == "ok"`` are never fitted. If leaving them out makes holes in the
grid, :func:`fit_surrogate` refuses unless ``allow_holes=True``; then only ``rbf_thin_plate``
can bridge the holes, and the surrogate lists them (:attr:`Surrogate.holes`).

Which surrogate the optimiser uses
----------------------------------
:data:`DEFAULT_METHOD` / :data:`DEFAULT_TARGET` (``rbf_thin_plate`` in ``log``): on an analytic
table sampled on the reference grid it had the lowest leave-one-plane-out error of the methods
(see :func:`cross_validate`; 13.6 % RMS against 13.9 % for tensor_spline and 14.9 % for
tensor_linear, all with the log target; 1.9 % RMS in leave-one-point-out), it is smooth (SLSQP's finite-difference gradients have no kinks at
grid lines), and it is the only method that works when the grid has holes.
:func:`select_surrogate` repeats that choice on a real table from its cross-validation.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.interpolate import RBFInterpolator, make_interp_spline

from pidpipe.design.ceq_table import (
    COORDINATE_COLUMNS,
    SEM_COLUMN,
    VALUE_COLUMN,
    split_usable,
    validate_ceq_table,
)
from pidpipe.errors import DomainError, TableError

#: Interpolation methods, see the module docstring.
METHODS: tuple[str, ...] = ("tensor_linear", "tensor_spline", "rbf_thin_plate")
#: Target transforms: "log" fits ln(C + c0), "linear" fits C.
TARGETS: tuple[str, ...] = ("log", "linear")
#: The surrogate the optimiser uses unless :func:`select_surrogate` says otherwise.
DEFAULT_METHOD = "rbf_thin_plate"
DEFAULT_TARGET = "log"
#: c0 = this fraction of the largest fitted C_eq (target "log").
DEFAULT_LOG_OFFSET_FRACTION = 1e-3
#: Relative errors in cross-validation are taken against max(|C|, this * max |C|).
RELATIVE_ERROR_FLOOR = 1e-3

_UNITS = {"freq_hz": "Hz", "accel_g": "g", "fill_pct": "%"}
_TENSOR_METHODS = ("tensor_linear", "tensor_spline")
_DOMAIN_TOLERANCE = 1e-9
_FILE_FORMAT = "pidpipe-surrogate"
_FILE_VERSION = 1


def _to_u(freq_hz: np.ndarray, accel_g: np.ndarray, fill_pct: np.ndarray) -> np.ndarray:
    """Physical coordinates -> interpolation coordinates u = (ln f, ln G, r), shape (m, 3)."""
    return np.column_stack([np.log(freq_hz), np.log(accel_g), fill_pct]).astype(float)


@dataclass
class Surrogate:
    """A fitted surrogate of C_eq_coupon(f, G, r); build it with :func:`fit_surrogate`.

    Attributes
    ----------
    method, target : str
        One of :data:`METHODS` and of :data:`TARGETS`.
    training : pandas.DataFrame
        The fitted rows (``freq_hz, accel_g, fill_pct, ceq_coupon_ns_m``, and
        ``ceq_coupon_sem_ns_m`` when the table has it: the figures mark uncertain points).
    domain : dict of str -> (float, float)
        Bounds of ``freq_hz`` (Hz), ``accel_g`` (g) and ``fill_pct`` (%).
    offset_ns_m : float
        c0 of the "log" target, N*s/m (0 for "linear").
    excluded : list of dict
        Rows left out of the fit (status not ok): coordinates, status and case_id if known.
    holes : list of tuple of float
        (f, G, r) grid points with no usable row that the fit bridged (``allow_holes=True``).
    options : dict
        The fit options, so that :func:`load_surrogate` can refit identically.
    """

    method: str
    target: str
    training: pd.DataFrame
    domain: dict[str, tuple[float, float]]
    offset_ns_m: float
    excluded: list[dict] = field(default_factory=list)
    holes: list[tuple[float, float, float]] = field(default_factory=list)
    options: dict = field(default_factory=dict)
    _model: object = field(default=None, repr=False)

    def predict(self, freq_hz, accel_g, fill_pct) -> np.ndarray | float:
        """C_eq of the coupon at (f, G, r), refusing queries outside the domain.

        Parameters
        ----------
        freq_hz, accel_g, fill_pct : float or array_like
            Frequency (Hz), base acceleration (g) and fill (%); broadcast together.

        Returns
        -------
        float or numpy.ndarray
            C_eq_coupon in N*s/m, with the broadcast shape of the inputs (a float for
            scalar inputs).

        Raises
        ------
        DomainError
            A value lies outside :attr:`domain` (the message names the variable, the value
            and the domain) or is not a finite number.
        """
        arrays = _as_query_arrays(freq_hz, accel_g, fill_pct)
        self.check_domain(*arrays)
        shape = arrays[0].shape
        values = self._predict(*(a.ravel() for a in arrays)).reshape(shape)
        return float(values) if values.ndim == 0 else values

    def check_domain(self, freq_hz, accel_g, fill_pct) -> None:
        """Raise :class:`DomainError` if any query value lies outside :attr:`domain`."""
        for name, values in zip(COORDINATE_COLUMNS, (freq_hz, accel_g, fill_pct)):
            lo, hi = self.domain[name]
            tol = _DOMAIN_TOLERANCE * (hi - lo)
            values = np.asarray(values, dtype=float)
            # min and max first (one pass each, no temporaries): the optimiser asks millions
            # of in-domain points, and this check was a third of a prediction's time
            if not values.size or (values.min() >= lo - tol and values.max() <= hi + tol):
                continue
            outside = (values < lo - tol) | (values > hi + tol)
            if np.any(outside):
                bad = values[outside].ravel()[0]
                unit = _UNITS[name]
                raise DomainError(
                    f"{name} = {bad:g} {unit} is outside the surrogate's domain "
                    f"[{lo:g}, {hi:g}] {unit}; the surrogate does not extrapolate "
                    f"(extend the C_eq grid, or bound the query to the domain)"
                )

    def _predict(self, freq_hz: np.ndarray, accel_g: np.ndarray,
                 fill_pct: np.ndarray) -> np.ndarray:
        """C_eq at m points, shape (m,), N*s/m; no input checks, no domain checks."""
        y = self._model(_to_u(freq_hz, accel_g, fill_pct))
        if self.target == "log":
            values = np.exp(y) - self.offset_ns_m
        else:
            values = np.asarray(y, dtype=float)
        return np.maximum(values, 0.0)

    def describe(self) -> str:
        """One paragraph for logs: method, points, domain, left-out rows and holes."""
        bounds = ", ".join(f"{k} [{lo:g}, {hi:g}] {_UNITS[k]}" for k, (lo, hi) in self.domain.items())
        text = (f"surrogate {self.method} ({self.target} target) on {len(self.training)} rows; "
                f"domain {bounds}; {len(self.excluded)} row(s) left out (status not ok)")
        if self.holes:
            text += f"; bridges {len(self.holes)} hole(s): {self.holes}"
        return text


def _as_query_arrays(freq_hz, accel_g, fill_pct) -> tuple[np.ndarray, ...]:
    """Broadcast the query to float arrays; refuse non-numeric and non-finite values."""
    arrays = []
    for name, value in zip(COORDINATE_COLUMNS, (freq_hz, accel_g, fill_pct)):
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError) as exc:
            raise DomainError(f"{name} must be a number or an array of numbers, got {value!r}") from exc
        if not np.isfinite(array).all():
            raise DomainError(f"{name} must be finite, got {value!r}")
        arrays.append(array)
    try:
        return tuple(np.broadcast_arrays(*arrays))
    except ValueError as exc:
        shapes = ", ".join(str(a.shape) for a in arrays)
        raise DomainError(f"freq_hz, accel_g, fill_pct have shapes {shapes} that do not broadcast") from exc


# --------------------------------------------------------------------------------------------
# Fitting


def fit_surrogate(table: pd.DataFrame, method: str = DEFAULT_METHOD, target: str = DEFAULT_TARGET,
                  log_offset_fraction: float = DEFAULT_LOG_OFFSET_FRACTION,
                  smoothing: float = 0.0, allow_holes: bool = False,
                  source: str = "<table>") -> Surrogate:
    """Fit a surrogate of C_eq_coupon to the usable rows of a C_eq table.

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table (validated again here); only ``status == "ok"`` rows are fitted.
    method : str
        One of :data:`METHODS`.
    target : str
        ``"log"`` (fit ln(C + c0)) or ``"linear"`` (fit C).
    log_offset_fraction : float
        c0 as a fraction of the largest fitted C_eq, > 0 (target "log").
    smoothing : float
        ``rbf_thin_plate`` only: RBFInterpolator's smoothing (0 interpolates exactly; > 0 fits
        noisy DEM values in the least-squares sense). Units of the transformed target squared.
    allow_holes : bool
        Let ``rbf_thin_plate`` bridge grid points that have no usable row (they are listed in
        :attr:`Surrogate.holes`). Tensor methods always need a complete grid.
    source : str
        Name of the table for error messages.

    Returns
    -------
    Surrogate

    Raises
    ------
    TableError
        Bad or missing values in the rows to fit, duplicated points, fewer levels along an axis
        than the method needs, holes in the grid (unless allowed), or an unknown option.
    """
    _check_options(method, target, log_offset_fraction, smoothing)
    table = validate_ceq_table(table, source=source)
    used, excluded = split_usable(table)
    if used.empty:
        raise TableError(f"C_eq table {source}: no row has status ok; nothing to fit")
    _check_duplicates(used, source)
    _check_levels(used, method, source)
    holes = _find_holes(table, used)
    _check_holes(holes, method, allow_holes, excluded, source)
    points = used[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    values = used[VALUE_COLUMN].to_numpy(dtype=float)
    offset, y = _target_values(values, target, log_offset_fraction)
    domain = {name: (float(points[:, i].min()), float(points[:, i].max()))
              for i, name in enumerate(COORDINATE_COLUMNS)}
    model = _build_model(method, points, y, domain, smoothing, source)
    return Surrogate(
        method=method, target=target,
        training=used[[c for c in (*COORDINATE_COLUMNS, VALUE_COLUMN, SEM_COLUMN, "regime")
                       if c in used.columns]].reset_index(drop=True),
        domain=domain, offset_ns_m=float(offset),
        excluded=_describe_rows(excluded), holes=holes,
        options={"log_offset_fraction": log_offset_fraction, "smoothing": smoothing,
                 "allow_holes": allow_holes},
        _model=model,
    )


def _target_values(values: np.ndarray, target: str, log_offset_fraction: float):
    """(c0, fitted y) of C_eq values: ln(C + c0) with c0 = fraction * max C, or C itself."""
    if target != "log":
        return 0.0, values
    offset = log_offset_fraction * values.max()
    if offset <= 0.0:
        offset = 1.0  # every value is 0: any positive offset gives the same (flat) surrogate
    return offset, np.log(values + offset)


def refit_values(surrogate: Surrogate, values) -> Surrogate:
    """The same surrogate (method, target, options, points) fitted to new C_eq values.

    The points are the ones :func:`fit_surrogate` already checked, so the table is not validated
    again (the bootstrap refits hundreds of times); the values must be finite and >= 0.

    Parameters
    ----------
    surrogate : Surrogate
    values : array_like, shape (n_rows,)
        C_eq_coupon at the training rows, in their order, N*s/m.

    Raises
    ------
    TableError
        A value is not finite or is negative, or the number of values is not the number of rows.
    """
    values = np.asarray(values, dtype=float)
    if values.shape != (len(surrogate.training),) or not np.all(np.isfinite(values) & (values >= 0)):
        raise TableError(f"refit needs {len(surrogate.training)} finite C_eq >= 0, got shape {values.shape}")
    points = surrogate.training[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    offset, y = _target_values(values, surrogate.target, surrogate.options.get(
        "log_offset_fraction", DEFAULT_LOG_OFFSET_FRACTION))
    training = surrogate.training.copy()
    training[VALUE_COLUMN] = values
    model = _build_model(surrogate.method, points, y, surrogate.domain,
                         surrogate.options.get("smoothing", 0.0), "refit")
    return Surrogate(method=surrogate.method, target=surrogate.target, training=training,
                     domain=dict(surrogate.domain), offset_ns_m=float(offset),
                     excluded=list(surrogate.excluded), holes=list(surrogate.holes),
                     options=dict(surrogate.options), _model=model)


def _check_options(method: str, target: str, log_offset_fraction: float, smoothing: float) -> None:
    """Refuse unknown methods and targets and non-positive offsets."""
    if method not in METHODS:
        raise TableError(f"surrogate method {method!r} is unknown; choose one of {', '.join(METHODS)}")
    if target not in TARGETS:
        raise TableError(f"surrogate target {target!r} is unknown; choose one of {', '.join(TARGETS)}")
    if not (np.isfinite(log_offset_fraction) and log_offset_fraction > 0):
        raise TableError(f"log_offset_fraction must be > 0, got {log_offset_fraction!r}")
    if not (np.isfinite(smoothing) and smoothing >= 0):
        raise TableError(f"smoothing must be >= 0, got {smoothing!r}")
    if smoothing > 0 and method != "rbf_thin_plate":
        raise TableError(f"smoothing applies to rbf_thin_plate only, not {method}")


def _check_duplicates(used: pd.DataFrame, source: str) -> None:
    """Refuse two usable rows at the same (f, G, r): an interpolant cannot take both values."""
    duplicated = used.duplicated(list(COORDINATE_COLUMNS), keep=False).to_numpy()
    if duplicated.any():
        rows = [int(used.index[i]) + 1 for i in np.flatnonzero(duplicated)]
        raise TableError(
            f"C_eq table {source}: rows {rows[:10]} repeat the same (freq_hz, accel_g, fill_pct); "
            f"average the repeats or mark all but one as flagged"
        )


def _levels(used: pd.DataFrame) -> dict[str, np.ndarray]:
    """Sorted distinct values of each coordinate among the used rows."""
    return {name: np.unique(used[name].to_numpy(dtype=float)) for name in COORDINATE_COLUMNS}


def _check_levels(used: pd.DataFrame, method: str, source: str) -> None:
    """Refuse an axis with fewer levels than the method needs, and too few RBF points."""
    needed = 2  # every method: an axis of one level has no extent to interpolate over
    for name, levels in _levels(used).items():
        if levels.size < needed:
            raise TableError(
                f"C_eq table {source}: {name} has {levels.size} distinct value(s) "
                f"({', '.join(f'{v:g}' for v in levels)}) among the status-ok rows; "
                f"method {method} needs at least {needed}"
            )
    if method == "rbf_thin_plate" and len(used) < 5:
        raise TableError(
            f"C_eq table {source}: rbf_thin_plate has {len(used)} status-ok points; it needs "
            f"at least 5 (4 for its linear tail in 3 variables, plus one)"
        )


def _find_holes(table: pd.DataFrame, used: pd.DataFrame) -> list[tuple[float, float, float]]:
    """Grid points (product of every row's levels) that no usable row covers."""
    coords = [c for c in COORDINATE_COLUMNS]
    finite = table[coords].notna().all(axis=1)
    levels = [np.unique(table.loc[finite, c].to_numpy(dtype=float)) for c in coords]
    covered = set(map(tuple, used[coords].to_numpy(dtype=float)))
    return [tuple(float(v) for v in p) for p in itertools.product(*levels) if p not in covered]


def _check_holes(holes: list, method: str, allow_holes: bool, excluded: pd.DataFrame,
                 source: str) -> None:
    """Refuse holes unless explicitly allowed and the method can bridge them."""
    if not holes:
        return
    shown = "; ".join(f"f={f:g} Hz, G={g:g} g, r={r:g} %" for f, g, r in holes[:6])
    more = f" and {len(holes) - 6} more" if len(holes) > 6 else ""
    status = ""
    if "status" in excluded.columns and not excluded.empty:
        counts = excluded["status"].value_counts().to_dict()
        status = " (rows left out: " + ", ".join(f"{v} {k}" for k, v in counts.items()) + ")"
    where = f"C_eq table {source}: the status-ok rows leave {len(holes)} grid point(s) empty{status}: {shown}{more}"
    if method in _TENSOR_METHODS:
        raise TableError(f"{where}; {method} needs a complete grid: rerun those cases, "
                         f"or use rbf_thin_plate with allow_holes")
    if not allow_holes:
        raise TableError(f"{where}; rerun those cases, or fit rbf_thin_plate with allow_holes=True "
                         f"to interpolate across them explicitly")


def _describe_rows(excluded: pd.DataFrame) -> list[dict]:
    """The left-out rows as plain dicts (coordinates, status, case_id) for reports and files."""
    keep = [c for c in ("case_id",) + COORDINATE_COLUMNS + ("status", "flags") if c in excluded.columns]
    records = excluded[keep].to_dict(orient="records")
    return [{k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in r.items()}
            for r in records]


def _build_model(method: str, points: np.ndarray, y: np.ndarray,
                 domain: dict[str, tuple[float, float]], smoothing: float, source: str):
    """The interpolant of y over u = (ln f, G, r): a callable from (m, 3) u to (m,) y."""
    u = _to_u(points[:, 0], points[:, 1], points[:, 2])
    if method == "rbf_thin_plate":
        return _RadialModel(u, y, domain, smoothing, source)
    degree_cap = 1 if method == "tensor_linear" else 3
    return _TensorModel(u, y, degree_cap)


class _TensorModel:
    """Tensor product of 1-D interpolating splines on a complete grid in u = (ln f, G, r).

    The 1-D spline through the unit vector e_j of an axis is that axis' j-th cardinal
    function L_j; the interpolant is sum_ijk L_i(u0) L_j(u1) L_k(u2) y_ijk.
    """

    def __init__(self, u: np.ndarray, y: np.ndarray, degree_cap: int) -> None:
        self.levels = [np.unique(u[:, i]) for i in range(3)]
        self.degrees = [min(degree_cap, lv.size - 1) for lv in self.levels]
        index = [np.searchsorted(lv, u[:, i]) for i, lv in enumerate(self.levels)]
        grid = np.full([lv.size for lv in self.levels], np.nan)
        grid[tuple(index)] = y
        self.values = grid
        self.cardinals = [make_interp_spline(lv, np.eye(lv.size), k=k)
                          for lv, k in zip(self.levels, self.degrees)]

    def __call__(self, u: np.ndarray) -> np.ndarray:
        basis = [np.atleast_2d(card(u[:, i])) for i, card in enumerate(self.cardinals)]
        return np.einsum("mi,mj,mk,ijk->m", basis[0], basis[1], basis[2], self.values)


class _RadialModel:
    """Thin-plate RBF with a linear tail, on u scaled to [0, 1] per axis by the domain."""

    def __init__(self, u: np.ndarray, y: np.ndarray, domain: dict[str, tuple[float, float]],
                 smoothing: float, source: str) -> None:
        lo = _to_u(*(np.array([domain[name][0]]) for name in COORDINATE_COLUMNS))[0]
        hi = _to_u(*(np.array([domain[name][1]]) for name in COORDINATE_COLUMNS))[0]
        self.lo, self.span = lo, hi - lo
        try:
            self.rbf = RBFInterpolator(self._scale(u), y, kernel="thin_plate_spline",
                                       degree=1, smoothing=smoothing)
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise TableError(f"C_eq table {source}: rbf_thin_plate cannot be fitted to these "
                             f"points ({exc}); they may all lie in one plane") from exc

    def _scale(self, u: np.ndarray) -> np.ndarray:
        return (u - self.lo) / self.span

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return self.rbf(self._scale(u))


# --------------------------------------------------------------------------------------------
# Save and load


def _check_points(surrogate: Surrogate) -> np.ndarray:
    """Query points at which a saved surrogate records its values: the domain's corners,
    its centre and the midpoints of its faces, shape (15, 3)."""
    bounds = [surrogate.domain[name] for name in COORDINATE_COLUMNS]
    corners = list(itertools.product(*bounds))
    centre = [0.5 * (lo + hi) for lo, hi in bounds]
    faces = []
    for i, (lo, hi) in enumerate(bounds):
        for v in (lo, hi):
            p = list(centre)
            p[i] = v
            faces.append(p)
    return np.array(corners + [centre] + faces, dtype=float)


def save_surrogate(surrogate: Surrogate, path: str | Path) -> None:
    """Write a surrogate as JSON: its options, its training rows and check values.

    Nothing executable is stored; :func:`load_surrogate` refits from the training rows and
    compares its predictions with the stored check values.

    Parameters
    ----------
    surrogate : Surrogate
    path : str or Path
        Output file (``.json``).
    """
    points = _check_points(surrogate)
    document = {
        "format": _FILE_FORMAT,
        "version": _FILE_VERSION,
        "method": surrogate.method,
        "target": surrogate.target,
        "options": surrogate.options,
        "domain": {k: list(v) for k, v in surrogate.domain.items()},
        "offset_ns_m": surrogate.offset_ns_m,
        "training": {c: surrogate.training[c].tolist() for c in surrogate.training.columns},
        "excluded": surrogate.excluded,
        "holes": [list(h) for h in surrogate.holes],
        "check_points": points.tolist(),
        "check_values_ns_m": surrogate._predict(points[:, 0], points[:, 1], points[:, 2]).tolist(),
    }
    Path(path).write_text(json.dumps(document, indent=1, default=_json_default))


def _json_default(value):
    """JSON encoder for numpy scalars."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def load_surrogate(path: str | Path, rtol: float = 1e-8) -> Surrogate:
    """Read a surrogate written by :func:`save_surrogate` and refit it.

    Parameters
    ----------
    path : str or Path
    rtol : float
        Relative tolerance between the refitted and the stored check values.

    Returns
    -------
    Surrogate

    Raises
    ------
    TableError
        The file is missing, not a surrogate file, or the refit does not reproduce the stored
        values (for instance under a different SciPy).
    """
    path = Path(path)
    try:
        document = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise TableError(f"surrogate file {path}: cannot be read ({exc})") from exc
    if document.get("format") != _FILE_FORMAT or document.get("version") != _FILE_VERSION:
        raise TableError(f"surrogate file {path}: not a {_FILE_FORMAT} version {_FILE_VERSION} file")
    options = document["options"]
    surrogate = fit_surrogate(pd.DataFrame(document["training"]), method=document["method"],
                              target=document["target"], source=str(path),
                              log_offset_fraction=options["log_offset_fraction"],
                              smoothing=options["smoothing"], allow_holes=options["allow_holes"])
    surrogate.excluded = document["excluded"]
    surrogate.holes = [tuple(h) for h in document["holes"]]
    surrogate.options = options
    points = np.array(document["check_points"], dtype=float)
    stored = np.array(document["check_values_ns_m"], dtype=float)
    refit = surrogate._predict(points[:, 0], points[:, 1], points[:, 2])
    scale = max(float(np.max(np.abs(stored))), 1e-300)
    if not np.allclose(refit, stored, rtol=rtol, atol=rtol * scale):
        worst = float(np.max(np.abs(refit - stored)))
        raise TableError(f"surrogate file {path}: the refitted surrogate differs from the saved "
                         f"one by up to {worst:g} N*s/m; refit it from the C_eq table")
    return surrogate


# --------------------------------------------------------------------------------------------
# Cross-validation and choice


def cross_validate(table: pd.DataFrame, methods: tuple[str, ...] = METHODS,
                   targets: tuple[str, ...] = TARGETS,
                   log_offset_fraction: float = DEFAULT_LOG_OFFSET_FRACTION,
                   schemes: tuple[str, ...] = ("point", "plane")) -> pd.DataFrame:
    """Leave-one-out cross-validation of every (method, target) on the usable rows.

    Two schemes:

    ``point``
        Leave out one grid point, refit on the others, predict it. Only ``rbf_thin_plate``
        can be refitted on a grid with one point missing.
    ``plane``
        Leave out every point of one interior level of one axis (e.g. all f = 500 Hz rows),
        refit on the remaining complete grid, predict them. Every method can do this, so it is
        the scheme that compares methods; it is pessimistic (the gap it opens is twice the
        grid spacing).

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table whose usable rows form a complete grid.
    methods, targets : tuple of str
        The candidates.
    log_offset_fraction : float
        As in :func:`fit_surrogate`.
    schemes : tuple of str
        The schemes to run (``point`` applies to rbf_thin_plate only).

    Returns
    -------
    pandas.DataFrame
        One row per (method, target, scheme) with ``n_folds``, ``n_predictions``,
        ``rms_rel_error``, ``max_rel_error`` (relative to max(|C|, 1e-3 max |C|)),
        ``rms_abs_error_ns_m``, ``max_abs_error_ns_m`` and the (f, G, r) of the worst point.
        Schemes with no fold (a 2-level grid has no interior level) are left out.
    """
    table = validate_ceq_table(table)
    used, _ = split_usable(table)
    used = used.reset_index(drop=True)
    rows = []
    for method in methods:
        for target in targets:
            for scheme in schemes:
                if scheme == "point" and method != "rbf_thin_plate":
                    continue
                row = _cross_validate_one(used, method, target, scheme, log_offset_fraction)
                if row is not None:
                    rows.append(row)
    return pd.DataFrame(rows)


def _folds(used: pd.DataFrame, scheme: str) -> list[np.ndarray]:
    """Boolean masks of the held-out rows, one per fold."""
    if scheme == "point":
        return [np.arange(len(used)) == i for i in range(len(used))]
    folds = []
    for name, levels in _levels(used).items():
        for level in levels[1:-1]:
            folds.append(used[name].to_numpy(dtype=float) == level)
    return folds


def _cross_validate_one(used: pd.DataFrame, method: str, target: str, scheme: str,
                        log_offset_fraction: float) -> dict | None:
    """Errors of one (method, target, scheme); None when the scheme has no fold."""
    folds = _folds(used, scheme)
    truth, predicted, where = [], [], []
    for held in folds:
        train = used.loc[~held]
        try:
            surrogate = fit_surrogate(train, method=method, target=target,
                                      log_offset_fraction=log_offset_fraction,
                                      allow_holes=(scheme == "point"))
        except TableError:
            continue  # this fold leaves too little to fit (e.g. an axis of one level)
        test = used.loc[held]
        pts = test[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
        predicted.append(surrogate._predict(pts[:, 0], pts[:, 1], pts[:, 2]))
        truth.append(test[VALUE_COLUMN].to_numpy(dtype=float))
        where.append(pts)
    if not predicted:
        return None
    n_folds = len(predicted)
    truth, predicted, where = np.concatenate(truth), np.concatenate(predicted), np.vstack(where)
    error = np.abs(predicted - truth)
    floor = RELATIVE_ERROR_FLOOR * float(np.max(np.abs(used[VALUE_COLUMN])))
    relative = error / np.maximum(np.abs(truth), max(floor, 1e-300))
    worst = int(np.argmax(relative))
    return {
        "method": method, "target": target, "scheme": scheme,
        "n_folds": n_folds, "n_predictions": int(truth.size),
        "rms_rel_error": float(np.sqrt(np.mean(relative**2))),
        "max_rel_error": float(relative[worst]),
        "rms_abs_error_ns_m": float(np.sqrt(np.mean(error**2))),
        "max_abs_error_ns_m": float(error.max()),
        "worst_freq_hz": float(where[worst, 0]), "worst_accel_g": float(where[worst, 1]),
        "worst_fill_pct": float(where[worst, 2]),
    }


def select_surrogate(cv: pd.DataFrame) -> tuple[str, str]:
    """The (method, target) the optimiser should use, from :func:`cross_validate`'s table.

    The candidate with the lowest RMS relative error in the ``plane`` scheme (the one every
    method shares) wins. Without plane folds (a grid with no interior level, such as the
    2 x 2 x 2 CI grid) nothing can be compared and the documented default
    (:data:`DEFAULT_METHOD`, :data:`DEFAULT_TARGET`) is returned.

    Parameters
    ----------
    cv : pandas.DataFrame
        The output of :func:`cross_validate`.

    Returns
    -------
    (str, str)
        method and target.
    """
    if cv.empty or "scheme" not in cv.columns:
        return DEFAULT_METHOD, DEFAULT_TARGET
    plane = cv[cv["scheme"] == "plane"]
    if plane.empty:
        return DEFAULT_METHOD, DEFAULT_TARGET
    best = plane.sort_values(["rms_rel_error", "max_rel_error"]).iloc[0]
    return str(best["method"]), str(best["target"])
