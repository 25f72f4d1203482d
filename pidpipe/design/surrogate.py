"""Surrogates of the coupon's C_eq (N*s/m) over (f [Hz], G [g], r [%]): the source's
interpolating splines, and a Gaussian process that fits each case with its noise.

Coordinates and target
----------------------
Every method works in ``u = (ln f, ln G, r)``. C_eq = E_d / (pi * omega * W^2) with
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
fits C itself. Either way a C_eq prediction is clipped at 0 N*s/m (dissipation is not negative;
an effective mass is not clipped, :attr:`Surrogate.nonnegative`); the clip only acts where an
interpolant overshoots below zero, i.e. at the scale of c0 for "log".

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

``gp``
    Gaussian-process regression with a known noise per case (:mod:`pidpipe.design.gaussian_process`,
    scikit-learn's ``GaussianProcessRegressor`` with per-sample ``alpha``): every case enters
    with its SEM (propagated to the transformed target to first order, ``alpha_i = (dy/dC)^2
    SEM_i^2``), an anisotropic Matern 5/2 kernel over u scaled to [0, 1] plus a fitted excess
    white noise, hyperparameters by maximum marginal likelihood. It does not interpolate the
    noisy values, and it has a predictive standard uncertainty of its own at any (f, G, r)
    (:meth:`Surrogate.predict_with_uncertainty`), from the cases' noise and from the distance
    to them. Its rows follow :func:`pidpipe.design.fit_policy.split_for_fit`: cases flagged
    for precision only (``target_not_reached``, ``not_resolved``, ``not_stationary``...) are
    fitted with their large SEM instead of leaving a hole; failed cases and failed checks are
    dropped. Its default target is ``log``. Cases shaken on the same packings (every case of a
    fill shares the pilot's) have correlated errors: with the table's ``packing_loads`` the
    noise is their covariance, not a diagonal (:mod:`pidpipe.design.packing_noise`).

Targets of the GP
-----------------
The GP knows each case's noise, so its log target needs no offset to hide noise: its c0 is the
smallest positive SEM of the fitted rows (it only keeps ln defined at C = 0; a value at the
noise level enters with a noise of order one or more in ln C and weighs accordingly). On the
DEM campaign's table, whose C_eq spans 0.0016 to 236 N*s/m, this resolves the 50-100 Hz / 1 g
cases that an offset of 1e-3 of the largest value (0.24 N*s/m) flattens (leave-one-out RMS
error 2.3 case SEMs against 2.7 with that offset, when it was measured, issue 26).
``asinh`` fits ``y = asinh(C / c0)`` with c0 the median SEM (linear below the noise level,
logarithmic above); it flattens those cases more (27 SEMs). ``linear`` fits C (643 SEMs: the
small values drown in the large ones' scatter). Figures from ``benchmarks/compare_surrogates.py``.
With any target the GP's Gaussian interval in y is mapped back through the monotone inverse
transform, so intervals in C are asymmetric where the target is a log.

Each case enters the GP as the first-order expansion of the target about the GP's fitted value
a, ``y = T(a) + T'(a) (C - a)``, with the noise ``(T'(a) SEM)^2`` of that same expansion
(``gp_observations="linearised"``, :func:`_fit_gp`): a case whose SEM is a large fraction of its
value is then Gaussian in y with the noise the GP is told, which ``T(C)`` is not. A surrogate
file written before keeps ``T(C)`` (``"transformed"``) when it is reloaded.

The surrogate is generic over the fitted column: ``value_column`` and ``sem_column`` (C_eq by
default; the effective mass ``m_eff_cell_kg`` / ``m_eff_cell_sem_kg`` the same way).

Domain and extrapolation policy
-------------------------------
The domain is the bounding box of the fitted rows, per variable. :meth:`Surrogate.predict`
refuses any query outside it with :class:`~pidpipe.errors.DomainError` (no extrapolation, no
silent clipping); a tolerance of 1e-9 of the axis span absorbs rounding only.

The spline methods fit the rows with ``status == "ok"`` (``rows="ok"``); ``gp`` fits the rows
of the fit policy (``rows="policy"``, :mod:`pidpipe.design.fit_policy`); either can be asked for
the other. If leaving rows out makes holes in the grid, :func:`fit_surrogate` refuses unless
``allow_holes=True``; then only ``rbf_thin_plate`` and ``gp`` can bridge the holes, and the
surrogate lists them (:attr:`Surrogate.holes`); ``gp`` bridges them with a larger uncertainty.

Which surrogate the optimiser uses
----------------------------------
:data:`DEFAULT_METHOD` / :data:`DEFAULT_TARGET` (``rbf_thin_plate`` in ``log``): on an analytic
table sampled on the reference grid it had the lowest leave-one-plane-out error of the methods
(see :func:`cross_validate`; 13.6 % RMS against 13.9 % for tensor_spline and 14.9 % for
tensor_linear, all with the log target; 1.9 % RMS in leave-one-point-out), it is smooth (SLSQP's finite-difference gradients have no kinks at
grid lines), and it is the only method that works when the grid has holes.
:func:`select_surrogate` repeats that choice on a real table from its cross-validation.

On the DEM campaign's table of the default grid (60 cases, 17 flagged: 15 at 1 g, 2 at 5 g for
``not_stationary``), ``benchmarks/compare_surrogates.py`` held every case out in turn and
divided each error by the case's SEM (1 is the case's own noise). RMS: ``gp`` (log) 2.3,
``rbf_thin_plate`` fitted to the status-ok rows 116 (it bridges the flagged 1 g cases from 5 g:
47-55 N*s/m at 450-500 Hz / 1 g / 25 %, where the GP gives 6.6-9.0 +- 1.4-1.8 and the case
measured 7.9 +- 4.8), ``rbf_thin_plate`` interpolating the flagged cases too 5.1. Leaving out
whole interior planes: ``gp`` 6.5, ``tensor_linear`` 8.6, ``rbf_thin_plate`` 9.5,
``tensor_spline`` 20.8. The GP's leave-one-out z-scores have a standard deviation of 0.87
(0.96 over the flagged cases, 0.84 over the ok ones); 77 % and 98 % of the held-out values lie
in its 68.3 % and 95 % intervals. Where the grid is too coarse for the response, between the
1 and 5 g levels, its intervals were too narrow (tests/design/test_surrogate_gp.py). Those
figures are from before the linearised observations; with them the z-scores' standard
deviation is 0.95 (1.15 flagged, 0.88 ok), the RMS error 2.30 SEMs, and the 95 % intervals
between 1 and 5 g cover the synthetic truth at their nominal rate.
"""

from __future__ import annotations

import contextlib

import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.interpolate import RBFInterpolator, make_interp_spline
# the normal's cdf and quantile, as scipy.stats' norm computes them, without importing scipy.stats
from scipy.special import ndtr, ndtri

from pidpipe.design.ceq_table import (
    COORDINATE_COLUMNS,
    SEM_COLUMN,
    VALUE_COLUMN,
    split_usable,
    validate_ceq_table,
)
from pidpipe.design.fit_policy import split_for_fit
from pidpipe.design.packing_noise import LOADS_COLUMN, SharedPackings
from pidpipe.errors import DomainError, TableError

#: Interpolating methods (the source's family), see the module docstring.
SPLINE_METHODS: tuple[str, ...] = ("tensor_linear", "tensor_spline", "rbf_thin_plate")
#: Every method: the interpolants and the noise-aware Gaussian process.
METHODS: tuple[str, ...] = SPLINE_METHODS + ("gp",)
#: Target transforms: "log" fits ln(C + c0), "linear" fits C, "asinh" fits asinh(C / c0).
TARGETS: tuple[str, ...] = ("log", "linear", "asinh")
#: Rows a fit uses: "ok" (status ok) or "policy" (:func:`pidpipe.design.fit_policy.split_for_fit`).
ROWS: tuple[str, ...] = ("ok", "policy")
#: Each method's target and rows when the caller does not choose.
METHOD_DEFAULTS: dict[str, tuple[str, str]] = {
    "tensor_linear": ("log", "ok"), "tensor_spline": ("log", "ok"),
    "rbf_thin_plate": ("log", "ok"), "gp": ("log", "policy")}
#: The surrogate the optimiser uses unless :func:`select_surrogate` says otherwise.
DEFAULT_METHOD = "rbf_thin_plate"
DEFAULT_TARGET = "log"
#: c0 = this fraction of the largest fitted C_eq (target "log").
DEFAULT_LOG_OFFSET_FRACTION = 1e-3
#: Relative errors in cross-validation are taken against max(|C|, this * max |C|).
RELATIVE_ERROR_FLOOR = 1e-3

_UNITS = {"freq_hz": "Hz", "accel_g": "g", "fill_pct": "%"}
_TENSOR_METHODS = ("tensor_linear", "tensor_spline")
_BRIDGING_METHODS = ("rbf_thin_plate", "gp")
#: gp's training column: the value at which each SEM was propagated to the target (its fit).
NOISE_AT_COLUMN = "noise_propagated_at"
#: How gp observes each case in the target (``options["gp_observations"]``): "linearised",
#: y = T(a) + T'(a) (C - a) with a the fitted value at which the SEM is propagated, or
#: "transformed", y = T(C) (surrogate files written before "linearised"; see _fit_gp).
GP_OBSERVATIONS: tuple[str, ...] = ("linearised", "transformed")
#: What a new gp fit uses.
DEFAULT_GP_OBSERVATIONS = "linearised"
#: Probability inside +-1 standard deviation of a normal distribution.
ONE_SIGMA = float(ndtr(1.0) - ndtr(-1.0))
_DOMAIN_TOLERANCE = 1e-9
_FILE_FORMAT = "pidpipe-surrogate"
_FILE_VERSION = 2
#: Versions :func:`load_surrogate` reads (1: before gp, value_column and sem_column).
_READABLE_VERSIONS = (1, 2)


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
        c0 of the "log" and "asinh" targets, in the value's unit (0 for "linear").
    excluded : list of dict
        Rows left out of the fit (status not ok): coordinates, status and case_id if known.
    holes : list of tuple of float
        (f, G, r) grid points with no usable row that the fit bridged (``allow_holes=True``).
    options : dict
        The fit options, so that :func:`load_surrogate` can refit identically (for ``gp`` also
        the fitted kernel's log-hyperparameters ``kernel_theta``).
    value_column, sem_column : str
        The fitted column and its SEM column.
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
    value_column: str = VALUE_COLUMN
    sem_column: str = SEM_COLUMN
    _bounds: dict = field(default_factory=dict, repr=False, compare=False)

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

    @property
    def has_uncertainty(self) -> bool:
        """Whether :meth:`predict_with_uncertainty` answers: only the Gaussian process (``gp``)
        has a predictive uncertainty of its own; the interpolants raise there."""
        return self.method == "gp"

    def predict_with_uncertainty(self, freq_hz, accel_g, fill_pct,
                                 include_scatter: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Prediction and its standard uncertainty at (f, G, r) (method ``gp`` only).

        The GP is Gaussian in the transformed target y; with posterior mean mu and standard
        deviation s, the prediction is ``T^-1(mu)`` (the same as :meth:`predict`) and its
        standard uncertainty is half the width of the central 68.3 % interval,
        ``(T^-1(mu + s) - T^-1(mu - s)) / 2``, which is the standard deviation where s is small
        and follows the asymmetry of a log-like target where it is not.

        Parameters
        ----------
        freq_hz, accel_g, fill_pct : float or array_like
            As in :meth:`predict`.
        include_scatter : bool
            False: the uncertainty of the response itself (what an infinitely long case would
            measure). True: add the fitted excess scatter between cases that their SEMs do not
            hold (compare with one new case, whose own SEM is then added separately).

        Returns
        -------
        value, uncertainty : numpy.ndarray
            Broadcast shape of the inputs, in the value's unit (N*s/m for C_eq).

        Raises
        ------
        DomainError
            As :meth:`predict`.
        TableError
            The method has no uncertainty of its own (the interpolating splines).
        """
        lo, hi = self.predict_interval(freq_hz, accel_g, fill_pct, ONE_SIGMA, include_scatter,
                                       clip=False)
        value = np.asarray(self.predict(freq_hz, accel_g, fill_pct), dtype=float)
        return value, 0.5 * (hi - lo)

    def predict_interval(self, freq_hz, accel_g, fill_pct, level: float = 0.95,
                         include_scatter: bool = False, clip: bool = True):
        """Central predictive interval of probability ``level`` at (f, G, r) (method ``gp``).

        Parameters
        ----------
        freq_hz, accel_g, fill_pct : float or array_like
            As in :meth:`predict`.
        level : float
            Probability inside the interval, in (0, 1).
        include_scatter : bool
            As in :meth:`predict_with_uncertainty`.
        clip : bool
            Clip the bounds at 0 (dissipation is not negative), as :meth:`predict` does.

        Returns
        -------
        lower, upper : numpy.ndarray
            Broadcast shape of the inputs, in the value's unit.
        """
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must be in (0, 1), got {level!r}")
        mu, sd = self._predict_transformed(freq_hz, accel_g, fill_pct, include_scatter)
        k = float(ndtri(0.5 + 0.5 * level))
        lower, upper = (_from_target(mu - k * sd, self.target, self.offset_ns_m),
                        _from_target(mu + k * sd, self.target, self.offset_ns_m))
        if clip and self.nonnegative:
            lower, upper = np.maximum(lower, 0.0), np.maximum(upper, 0.0)
        return lower, upper

    def _predict_transformed(self, freq_hz, accel_g, fill_pct,
                             include_scatter: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """GP posterior mean and standard deviation of the transformed target, broadcast shape."""
        if self.method != "gp":
            raise TableError(f"surrogate {self.method} interpolates and has no uncertainty of its "
                             f"own; fit method gp for one")
        arrays = _as_query_arrays(freq_hz, accel_g, fill_pct)
        self.check_domain(*arrays)
        shape = arrays[0].shape
        u = self._model_input(*(a.ravel() for a in arrays))
        mu, sd = self._model.predict(u, include_white=include_scatter)
        return mu.reshape(shape), sd.reshape(shape)

    def _model_input(self, freq_hz: np.ndarray, accel_g: np.ndarray,
                     fill_pct: np.ndarray) -> np.ndarray:
        """What the model takes: u for the splines, u scaled to [0, 1] by the domain for gp."""
        u = _to_u(freq_hz, accel_g, fill_pct)
        if self.method != "gp":
            return u
        lo, span = self._domain_bounds()["scaling"]
        return (u - lo) / span

    def _domain_bounds(self) -> dict:
        """What every query needs from :attr:`domain`, computed once per domain: the GP's
        scaling (:func:`_scaling`) and each axis's accepted range with its tolerance. The
        optimiser asks hundreds of thousands of one-point predictions, and recomputing these
        took a third of each."""
        key = tuple(self.domain.items())
        if self._bounds.get("key") != key:
            accepted = {}
            for name in COORDINATE_COLUMNS:
                lo, hi = self.domain[name]
                tol = _DOMAIN_TOLERANCE * (hi - lo)
                accepted[name] = (lo - tol, hi + tol)
            self._bounds.clear()
            self._bounds.update(key=key, accepted=accepted, scaling=_scaling(self.domain))
        return self._bounds

    def check_domain(self, freq_hz, accel_g, fill_pct) -> None:
        """Raise :class:`DomainError` if any query value lies outside :attr:`domain`."""
        accepted = self._domain_bounds()["accepted"]
        for name, values in zip(COORDINATE_COLUMNS, (freq_hz, accel_g, fill_pct)):
            low, high = accepted[name]
            values = np.asarray(values, dtype=float)
            # min and max first (one pass each, no temporaries): the optimiser asks millions
            # of in-domain points, and this check was a third of a prediction's time
            if not values.size or (values.min() >= low and values.max() <= high):
                continue
            outside = (values < low) | (values > high)
            if np.any(outside):
                bad = values[outside].ravel()[0]
                unit = _UNITS[name]
                lo, hi = self.domain[name]
                raise DomainError(
                    f"{name} = {bad:g} {unit} is outside the surrogate's domain "
                    f"[{lo:g}, {hi:g}] {unit}; the surrogate does not extrapolate "
                    f"(extend the C_eq grid, or bound the query to the domain)"
                )

    def _predict(self, freq_hz: np.ndarray, accel_g: np.ndarray,
                 fill_pct: np.ndarray) -> np.ndarray:
        """C_eq at m points, shape (m,), N*s/m; no input checks, no domain checks."""
        y = self._model(self._model_input(freq_hz, accel_g, fill_pct))
        values = _from_target(y, self.target, self.offset_ns_m)
        return np.maximum(values, 0.0) if self.nonnegative else values

    @property
    def nonnegative(self) -> bool:
        """Whether predictions are clipped at 0: a C_eq column's (dissipation is not negative),
        not an effective mass's (an airborne bed's in-phase force can be slightly negative)."""
        return self.value_column.startswith("ceq_")

    def describe(self) -> str:
        """One paragraph for logs: method, points, domain, left-out rows and holes."""
        bounds = ", ".join(f"{k} [{lo:g}, {hi:g}] {_UNITS[k]}" for k, (lo, hi) in self.domain.items())
        text = (f"surrogate {self.method} ({self.target} target) on {len(self.training)} rows; "
                f"domain {bounds}; {len(self.excluded)} row(s) left out "
                f"({'by the fit policy' if self.options.get('rows') == 'policy' else 'status not ok'})")
        if self.method == "gp":
            model = self._model
            text += (f"; GP length scales (ln f, ln G, r; domain = 1) "
                     f"{', '.join(f'{v:.3g}' for v in model.length_scales)}, excess scatter "
                     f"{np.sqrt(model.white):.3g} ({self.target} units)")
        if self.holes:
            text += f"; bridges {len(self.holes)} hole(s): {listed_points(self.holes)}"
        return text


#: Points a log line lists before it only counts the rest.
LISTED_POINTS = 8


def listed_points(points) -> str:
    """Points for a log line: the first :data:`LISTED_POINTS`, then how many more.

    A refined table's levels make a product grid of thousands of points, most of them never
    meant to be run; a warning that listed them all was unreadable.
    """
    points = list(points)
    shown = ", ".join(str(tuple(point)) for point in points[:LISTED_POINTS])
    more = len(points) - LISTED_POINTS
    return shown + (f" and {more} more" if more > 0 else "")


def _from_target(y, target: str, offset: float) -> np.ndarray:
    """Inverse of the target transform: C from y (unclipped), value's unit."""
    y = np.asarray(y, dtype=float)
    if target == "log":
        return np.exp(y) - offset
    if target == "asinh":
        return offset * np.sinh(y)
    return y


def _scale_u(u: np.ndarray, domain: dict[str, tuple[float, float]]) -> np.ndarray:
    """u = (ln f, ln G, r) scaled to [0, 1] per axis by the domain, shape (m, 3)."""
    lo, span = _scaling(domain)
    return (u - lo) / span


def _scaling(domain: dict[str, tuple[float, float]]) -> tuple[np.ndarray, np.ndarray]:
    """The domain's lower corner in u and its span per axis (1 where the axis has one level),
    shape (3,) each: scaled u = (u - lo) / span."""
    lo = _to_u(*(np.array([domain[name][0]]) for name in COORDINATE_COLUMNS))[0]
    hi = _to_u(*(np.array([domain[name][1]]) for name in COORDINATE_COLUMNS))[0]
    return lo, np.where(hi > lo, hi - lo, 1.0)


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
    if arrays[0].shape == arrays[1].shape == arrays[2].shape:
        return tuple(arrays)    # nothing to broadcast (the optimiser's calls): skip its cost
    try:
        return tuple(np.broadcast_arrays(*arrays))
    except ValueError as exc:
        shapes = ", ".join(str(a.shape) for a in arrays)
        raise DomainError(f"freq_hz, accel_g, fill_pct have shapes {shapes} that do not broadcast") from exc


# --------------------------------------------------------------------------------------------
# Fitting


def fit_surrogate(table: pd.DataFrame, method: str = DEFAULT_METHOD, target: str | None = None,
                  log_offset_fraction: float = DEFAULT_LOG_OFFSET_FRACTION,
                  smoothing: float = 0.0, allow_holes: bool = False,
                  source: str = "<table>", rows: str | None = None,
                  value_column: str = VALUE_COLUMN, sem_column: str = SEM_COLUMN,
                  kernel_theta=None, gp_observations: str = DEFAULT_GP_OBSERVATIONS,
                  kernel_start=None) -> Surrogate:
    """Fit a surrogate of C_eq_coupon (or of another value column) to a C_eq table.

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table (validated again here), n rows.
    method : str
        One of :data:`METHODS`.
    target : str, optional
        ``"log"`` (fit ln(C + c0)), ``"linear"`` (fit C) or ``"asinh"`` (fit asinh(C / c0));
        by default the method's (:data:`METHOD_DEFAULTS`).
    log_offset_fraction : float
        c0 as a fraction of the largest fitted value, > 0 (the splines' "log" and "asinh"; gp
        takes c0 from the SEMs, see the module docstring).
    smoothing : float
        ``rbf_thin_plate`` only: RBFInterpolator's smoothing (0 interpolates exactly; > 0 fits
        noisy DEM values in the least-squares sense). Units of the transformed target squared.
    allow_holes : bool
        Let ``rbf_thin_plate`` or ``gp`` bridge grid points that have no fitted row (they are
        listed in :attr:`Surrogate.holes`). Tensor methods always need a complete grid.
    source : str
        Name of the table for error messages.
    rows : str, optional
        ``"ok"`` (status ok rows) or ``"policy"`` (:func:`pidpipe.design.fit_policy.split_for_fit`);
        by default the method's (:data:`METHOD_DEFAULTS`).
    value_column, sem_column : str
        The fitted column and its SEM (``gp`` needs the SEM in every fitted row).
    kernel_theta : array_like, optional
        ``gp`` only: log-hyperparameters of an earlier fit; the kernel is then not optimised
        (how :func:`load_surrogate` rebuilds a saved GP exactly).
    kernel_start : array_like, optional
        ``gp`` only: log-hyperparameters to start the kernel's optimiser from, without restarts
        (a cross-validation fold starts from the whole table's fit, whose optimum lies near its
        own); by default the optimiser starts from the initial kernel and
        :data:`pidpipe.design.gaussian_process.RESTARTS` random kernels.
    gp_observations : str
        ``gp`` only: one of :data:`GP_OBSERVATIONS` (how each case's value enters the target;
        ``"transformed"`` only to rebuild a file written before ``"linearised"``).

    Returns
    -------
    Surrogate

    Raises
    ------
    TableError
        Bad or missing values in the rows to fit, duplicated points, fewer levels along an axis
        than the method needs, holes in the grid (unless allowed), no SEMs for ``gp``, or an
        unknown option.
    """
    default_target, default_rows = METHOD_DEFAULTS.get(method, (DEFAULT_TARGET, "ok"))
    target = default_target if target is None else target
    rows = default_rows if rows is None else rows
    _check_options(method, target, log_offset_fraction, smoothing, rows)
    if gp_observations not in GP_OBSERVATIONS:
        raise TableError(f"gp_observations must be one of {GP_OBSERVATIONS}, got {gp_observations!r}")
    table = validate_ceq_table(table, source=source)
    if value_column not in table.columns:
        raise TableError(f"C_eq table {source}: no column {value_column} to fit")
    if rows == "policy":
        if sem_column not in table.columns:
            raise TableError(f"C_eq table {source}: surrogate method {method} fits each case with "
                             f"its SEM, and the table has no column {sem_column}; for a table "
                             f"without SEMs set surrogate.method to rbf_thin_plate or tensor_spline")
        used, excluded = split_for_fit(table, value_column, sem_column)
    else:
        used, excluded = split_usable(table)
    if used.empty:
        raise TableError(f"C_eq table {source}: no row to fit ({rows} rows)")
    values = used[value_column].to_numpy(dtype=float)
    if not np.all(np.isfinite(values)):
        raise TableError(f"C_eq table {source}: {value_column} is not finite in a row to fit")
    sems = _fit_sems(used, method, sem_column, source)
    _check_duplicates(used, source)
    _check_levels(used, method, source)
    holes = _find_holes(table, used)
    _check_holes(holes, method, allow_holes, excluded, source)
    points = used[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    offset = _target_offset(values, sems if method == "gp" else None, target, log_offset_fraction)
    domain = {name: (float(points[:, i].min()), float(points[:, i].max()))
              for i, name in enumerate(COORDINATE_COLUMNS)}
    options = {"log_offset_fraction": log_offset_fraction, "smoothing": smoothing,
               "allow_holes": allow_holes, "rows": rows}
    noise_at = None
    if method == "gp":
        stored = (used[NOISE_AT_COLUMN].to_numpy(dtype=float)
                  if kernel_theta is not None and NOISE_AT_COLUMN in used.columns else None)
        loads = SharedPackings.of(used) if value_column == VALUE_COLUMN else None
        model, noise_at = _fit_gp(points, values, sems, target, offset, domain, kernel_theta, stored,
                                  gp_observations, loads, kernel_start)
        options["kernel_theta"] = model.theta.tolist()
        options["gp_observations"] = gp_observations
    else:
        y, _ = _to_target(values, None, target, offset)
        model = _build_model(method, points, y, domain, smoothing, source)
    keep = [c for c in (*COORDINATE_COLUMNS, value_column, sem_column, VALUE_COLUMN, "status",
                        "flags", "regime", LOADS_COLUMN) if c in used.columns]
    training = used[list(dict.fromkeys(keep))].reset_index(drop=True)
    if noise_at is not None:
        training[NOISE_AT_COLUMN] = noise_at
    return Surrogate(
        method=method, target=target,
        training=training,
        domain=domain, offset_ns_m=float(offset),
        excluded=_describe_rows(excluded), holes=holes, options=options, _model=model,
        value_column=value_column, sem_column=sem_column,
    )


def _fit_sems(used: pd.DataFrame, method: str, sem_column: str, source: str) -> np.ndarray | None:
    """The SEMs of the fitted rows, shape (n,); None when there are none (splines only)."""
    if sem_column not in used.columns:
        if method == "gp":
            raise TableError(f"C_eq table {source}: gp fits each case with its SEM, and the "
                             f"table has no column {sem_column}")
        return None
    sems = used[sem_column].to_numpy(dtype=float)
    if not np.all(np.isfinite(sems) & (sems >= 0)):
        if method == "gp":
            raise TableError(f"C_eq table {source}: gp needs a finite SEM >= 0 in every fitted "
                             f"row; {sem_column} is not in {int(np.sum(~np.isfinite(sems)))} row(s)")
        return None
    return sems


def _target_offset(values: np.ndarray, sems: np.ndarray | None, target: str,
                   log_offset_fraction: float) -> float:
    """c0 of the target, value units: 0 for "linear"; with SEMs (gp), the smallest positive SEM
    for "log" and the median SEM for "asinh"; else ``log_offset_fraction * max |C|``."""
    if target == "linear":
        return 0.0
    positive = sems[sems > 0] if sems is not None else np.array([])
    if positive.size and target == "log":
        return float(positive.min())
    if positive.size and target == "asinh":
        return float(np.median(positive))
    offset = log_offset_fraction * float(np.max(np.abs(values)))
    return offset if offset > 0.0 else 1.0  # every value 0: any offset gives the same surrogate


def _to_target(values: np.ndarray, sems: np.ndarray | None, target: str, offset: float,
               at: np.ndarray | None = None):
    """(y, noise variance of y) of values and SEMs; the noise to first order in SEM, with the
    transform's slope taken at ``at`` (default: the values; None without SEMs). "log" fits
    max(C, 0): a slightly negative mean near zero is zero."""
    values = np.asarray(values, dtype=float)
    at = values if at is None else np.asarray(at, dtype=float)
    if target == "log":
        y, slope = np.log(np.maximum(values, 0.0) + offset), 1.0 / (np.maximum(at, 0.0) + offset)
    elif target == "asinh":
        y, slope = np.arcsinh(values / offset), 1.0 / np.hypot(at, offset)
    else:
        y, slope = values, np.ones_like(values)
    return y, (None if sems is None else (slope * np.asarray(sems, dtype=float)) ** 2)


def _fit_gp(points: np.ndarray, values: np.ndarray, sems: np.ndarray, target: str, offset: float,
            domain: dict, kernel_theta=None, noise_at=None,
            observations: str = DEFAULT_GP_OBSERVATIONS, loads: SharedPackings | None = None,
            kernel_start=None):
    """The GP of a surrogate and the values its noise was propagated at, shape (n,).

    The slope of the target transform that turns a SEM into a noise in y is taken at the GP's
    own fitted value, not at the noisy observation: at the observation, a draw above the truth
    gets a smaller noise in a log-like y than one below it, and the fit leans upward (on
    synthetic tables with 30 % noise at 1 g this put the GP a standard deviation above the truth
    there on average; at the fitted value it is not). One fit at the observations gives the
    fitted values, a second fit uses them, its optimiser started from the first fit's kernel.
    ``noise_at`` given (a reload) skips the first fit.

    The second fit observes each case as the same first-order expansion about the fitted value
    a that gives its noise (``observations="linearised"``): y = T(a) + T'(a) (C - a), whose
    noise is then Gaussian with exactly the variance (T'(a) SEM)^2 the GP is told, when C is
    normal about the truth with that SEM. The transformed value T(C) ("transformed") is not,
    where the SEM is a large fraction of C: ln C of a normal draw is skewed, and a draw near
    zero lands several log units below, far outside its stated noise. On synthetic tables with
    the DEM campaign's relative SEMs (up to 65 % at 0.5 and 1 g) the transformed values' 68.3 %
    and 95 % intervals covered the truth at 63.8 % and 92.0 % of the grid points and at 54-56 %
    and 71-87 % between 0.5 and 2 g; the linearised ones at 66.6 % and 95.1 %, and 64 % and
    90-92 % (``benchmarks/compare_surrogates.py ... --synthetic 40 --onset-g 0.25``). The two
    agree where the SEM is small.

    ``loads`` (:class:`pidpipe.design.packing_noise.SharedPackings`, loads in N*s/m): the
    cases' errors shared through their packings. The noise is then their covariance
    (:func:`pidpipe.design.packing_noise.noise_covariance`), the loads scaled row by row with
    the same slope T'(a) as the SEMs, and the GP cannot average away an offset that cases of
    one fill share; without packings in common (None), the independent noise above.

    ``kernel_start`` (log-hyperparameters): the first fit's optimiser starts there, without
    restarts (:func:`fit_surrogate`).
    """
    from pidpipe.design.gaussian_process import fit_gaussian_process  # scikit-learn: only a gp

    x = _scale_u(_to_u(*points.T), domain)
    if noise_at is None:
        y, noise = _to_target(values, sems, target, offset)
        noise = _with_shared(noise, loads, values, target, offset, values)
        first = fit_gaussian_process(x, y, noise, theta=kernel_theta, start=kernel_start)
        noise_at = _from_target(first(x), target, offset)
        start = first.theta
    else:
        start = None
    y, noise = _observations(values, sems, target, offset, noise_at, observations)
    noise = _with_shared(noise, loads, values, target, offset, noise_at)
    return (fit_gaussian_process(x, y, noise, theta=kernel_theta, start=start),
            np.asarray(noise_at, dtype=float))


def _with_shared(noise: np.ndarray, loads: SharedPackings | None, values: np.ndarray, target: str,
                 offset: float, at: np.ndarray) -> np.ndarray:
    """The noise (n,) as a covariance (n, n) with the packings' shared part, slopes taken at
    ``at``; ``noise`` itself when no two rows share a packing."""
    if loads is None:
        return noise
    _, slope_squared = _to_target(values, np.ones_like(values), target, offset, at=at)
    return loads.covariance(noise, np.sqrt(slope_squared))


def _observations(values: np.ndarray, sems: np.ndarray | None, target: str, offset: float,
                  at: np.ndarray, observations: str):
    """(y, noise variance of y) of a gp's cases: "transformed" y = T(C), or "linearised"
    y = T(a) + T'(a) (C - a) about ``at`` (a; for "log" max(a, 0)); the noise (T'(a) SEM)^2."""
    y, noise = _to_target(values, sems, target, offset, at=at)
    if observations == "linearised" and target != "linear":
        at = np.asarray(at, dtype=float)
        about = np.maximum(at, 0.0) if target == "log" else at
        y_about, slope_squared = _to_target(about, np.ones_like(about), target, offset, at=about)
        y = y_about + np.sqrt(slope_squared) * (np.asarray(values, dtype=float) - about)
    return y, noise


def _target_values(values: np.ndarray, target: str, log_offset_fraction: float):
    """(c0, fitted y) of C_eq values without SEMs (the spline targets)."""
    offset = _target_offset(values, None, target, log_offset_fraction)
    return offset, _to_target(values, None, target, offset)[0]


def refit_values(surrogate: Surrogate, values) -> Surrogate:
    """The same surrogate (method, target, options, points) fitted to new values.

    The points are the ones :func:`fit_surrogate` already checked, so the table is not validated
    again (the bootstrap refits hundreds of times); the values must be finite and >= 0. A ``gp``
    keeps its kernel's hyperparameters, its c0 and its rows' noise: only the values change.

    Parameters
    ----------
    surrogate : Surrogate
    values : array_like, shape (n_rows,)
        The fitted column at the training rows, in their order (N*s/m for C_eq).

    Raises
    ------
    TableError
        A value is not finite or is negative, or the number of values is not the number of rows.
    """
    values = np.asarray(values, dtype=float)
    if values.shape != (len(surrogate.training),) or not np.all(np.isfinite(values) & (values >= 0)):
        raise TableError(f"refit needs {len(surrogate.training)} finite values >= 0, got shape {values.shape}")
    points = surrogate.training[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    training = surrogate.training.copy()
    training[surrogate.value_column] = values
    if surrogate.method == "gp":
        offset = surrogate.offset_ns_m
        y, _ = _observations(values, None, surrogate.target, offset,
                             surrogate.training[NOISE_AT_COLUMN].to_numpy(dtype=float),
                             surrogate.options.get("gp_observations", "transformed"))
        model = surrogate._model.refit(y, surrogate._model.noise)
    else:
        offset, y = _target_values(values, surrogate.target, surrogate.options.get(
            "log_offset_fraction", DEFAULT_LOG_OFFSET_FRACTION))
        model = _build_model(surrogate.method, points, y, surrogate.domain,
                             surrogate.options.get("smoothing", 0.0), "refit")
    return Surrogate(method=surrogate.method, target=surrogate.target, training=training,
                     domain=dict(surrogate.domain), offset_ns_m=float(offset),
                     excluded=list(surrogate.excluded), holes=list(surrogate.holes),
                     options=dict(surrogate.options), _model=model,
                     value_column=surrogate.value_column, sem_column=surrogate.sem_column)


def _check_options(method: str, target: str, log_offset_fraction: float, smoothing: float,
                   rows: str = "ok") -> None:
    """Refuse unknown methods, targets and rows and non-positive offsets."""
    if method not in METHODS:
        raise TableError(f"surrogate method {method!r} is unknown; choose one of {', '.join(METHODS)}")
    if target not in TARGETS:
        raise TableError(f"surrogate target {target!r} is unknown; choose one of {', '.join(TARGETS)}")
    if rows not in ROWS:
        raise TableError(f"surrogate rows {rows!r} is unknown; choose one of {', '.join(ROWS)}")
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
                         f"or use rbf_thin_plate or gp with allow_holes")
    if not allow_holes:
        raise TableError(f"{where}; rerun those cases, or fit {method if method in _BRIDGING_METHODS else 'rbf_thin_plate'} "
                         f"with allow_holes=True to bridge them explicitly")


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
    compares its predictions with the stored check values. A ``gp`` stores its fitted kernel's
    log-hyperparameters in ``options["kernel_theta"]`` (and the kernel as text in ``gp_kernel``
    for a reader); its training rows keep their SEMs, status and flags, so the reload conditions
    the same kernel (``optimizer=None``) on the same values and noise, and the check values
    include its standard uncertainty.

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
        "value_column": surrogate.value_column,
        "sem_column": surrogate.sem_column,
        "training": {c: surrogate.training[c].tolist() for c in surrogate.training.columns},
        "excluded": surrogate.excluded,
        "holes": [list(h) for h in surrogate.holes],
        "check_points": points.tolist(),
        "check_values_ns_m": surrogate._predict(points[:, 0], points[:, 1], points[:, 2]).tolist(),
    }
    if surrogate.method == "gp":
        document["gp_kernel"] = surrogate._model.to_dict()["kernel"]
        document["check_uncertainty_ns_m"] = surrogate.predict_with_uncertainty(*points.T)[1].tolist()
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
    if document.get("format") != _FILE_FORMAT or document.get("version") not in _READABLE_VERSIONS:
        raise TableError(f"surrogate file {path}: not a {_FILE_FORMAT} file of version "
                         f"{' or '.join(map(str, _READABLE_VERSIONS))}")
    options = document["options"]
    surrogate = fit_surrogate(pd.DataFrame(document["training"]), method=document["method"],
                              target=document["target"], source=str(path),
                              log_offset_fraction=options["log_offset_fraction"],
                              smoothing=options["smoothing"], allow_holes=options["allow_holes"],
                              rows=options.get("rows", "ok"),
                              value_column=document.get("value_column", VALUE_COLUMN),
                              sem_column=document.get("sem_column", SEM_COLUMN),
                              kernel_theta=options.get("kernel_theta"),
                              gp_observations=options.get("gp_observations", "transformed"))
    surrogate.excluded = document["excluded"]
    surrogate.holes = [tuple(h) for h in document["holes"]]
    surrogate.options = options
    points = np.array(document["check_points"], dtype=float)
    stored = np.array(document["check_values_ns_m"], dtype=float)
    refit = surrogate._predict(points[:, 0], points[:, 1], points[:, 2])
    scale = max(float(np.max(np.abs(stored))), 1e-300)
    if "check_uncertainty_ns_m" in document:
        refit = np.concatenate([refit, surrogate.predict_with_uncertainty(*points.T)[1]])
        stored = np.concatenate([stored, np.array(document["check_uncertainty_ns_m"], dtype=float)])
    if not np.allclose(refit, stored, rtol=rtol, atol=rtol * scale):
        worst = float(np.max(np.abs(refit - stored)))
        raise TableError(f"surrogate file {path}: the refitted surrogate differs from the saved "
                         f"one by up to {worst:g} N*s/m; refit it from the C_eq table")
    return surrogate


# --------------------------------------------------------------------------------------------
# Cross-validation and choice


#: Where a cross-validation fold's GP optimiser starts (:func:`loo_predictions`).
FOLD_STARTS = ("table", "restarts")


def cross_validate(table: pd.DataFrame, methods: tuple[str, ...] = METHODS,
                   targets: tuple[str, ...] | None = None,
                   log_offset_fraction: float = DEFAULT_LOG_OFFSET_FRACTION,
                   schemes: tuple[str, ...] = ("point", "plane"), rows: str | None = None,
                   value_column: str = VALUE_COLUMN, sem_column: str = SEM_COLUMN,
                   workers: int = 1, fold_start: str = "table") -> pd.DataFrame:
    """Leave-one-out cross-validation of every (method, target) on the fitted rows.

    Two schemes:

    ``point``
        Leave out one grid point, refit on the others, predict it. Only ``rbf_thin_plate`` and
        ``gp`` can be refitted on a grid with one point missing.
    ``plane``
        Leave out every point of one interior level of one axis (e.g. all f = 500 Hz rows),
        refit on the remaining grid, predict them. Every method can do this on a complete grid,
        so it is the scheme that compares methods; it is pessimistic (the gap it opens is twice
        the grid spacing).

    A ``gp`` is refitted in every fold, hyperparameters included; by default (``fold_start``
    ``"table"``) each fold's optimiser starts from the hyperparameters fitted to all the rows,
    without restarts (see :func:`loo_predictions`).

    Parameters
    ----------
    table : pandas.DataFrame
        A C_eq table.
    methods : tuple of str
        The candidates; ``gp`` is skipped when the table has no SEMs.
    targets : tuple of str, optional
        The targets tried with every method; by default ``log`` and ``linear`` for the splines
        and the default target (``log``) for ``gp``.
    log_offset_fraction : float
        As in :func:`fit_surrogate`.
    schemes : tuple of str
        The schemes to run (``point`` applies to rbf_thin_plate and gp only).
    rows : str, optional
        ``"ok"`` or ``"policy"`` for every method (the held-out rows and the fitted rows);
        by default each method's own (:data:`METHOD_DEFAULTS`).
    value_column, sem_column : str
        As in :func:`fit_surrogate`.
    workers : int
        Folds fitted at once, each in a worker process (the folds are independent: the result
        does not depend on it).
    fold_start : str
        ``gp`` only: ``"table"`` or ``"restarts"`` (:func:`loo_predictions`).

    Returns
    -------
    pandas.DataFrame
        One row per (method, target, scheme) with ``rows``, ``n_folds``, ``n_predictions``,
        ``rms_rel_error``, ``max_rel_error`` (relative to max(|C|, 1e-3 max |C|)),
        ``rms_abs_error_ns_m``, ``max_abs_error_ns_m``, the (f, G, r) of the worst point, and
        with SEMs ``rms_error_per_sem`` (RMS of (prediction - value) / SEM: about 1 at best,
        as the held-out value has its own noise) and, for ``gp``, ``z_mean``, ``z_std`` (of
        the held-out values' z-scores against the prediction's uncertainty, its excess scatter
        and the value's SEM, in the transformed target: 0 and 1 when calibrated),
        ``coverage_68`` and ``coverage_95`` (fractions of held-out values inside the 68.3 %
        and 95 % intervals). Schemes with no fold are left out.
    """
    with fold_workers(workers) if workers > 1 else contextlib.nullcontext() as executor:
        return _cross_validate(table, methods, targets, log_offset_fraction, schemes, rows,
                               value_column, sem_column, executor, fold_start)


def fold_workers(workers: int):
    """Worker processes for cross-validation folds (a ``ProcessPoolExecutor``; use it in a
    ``with``)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    return ProcessPoolExecutor(int(workers), mp_context=multiprocessing.get_context("spawn"))


def _cross_validate(table, methods, targets, log_offset_fraction, schemes, rows, value_column,
                    sem_column, executor, fold_start="table") -> pd.DataFrame:
    """:func:`cross_validate`, its folds fitted in ``executor`` (None: here)."""
    rows_out = []
    has_sems = sem_column in table.columns
    for method in methods:
        if method == "gp" and not has_sems:
            continue
        for target in (targets or (("log", "linear") if method in SPLINE_METHODS
                                   else (METHOD_DEFAULTS[method][0],))):
            for scheme in schemes:
                if scheme == "point" and method not in _BRIDGING_METHODS:
                    continue
                points = loo_predictions(table, method, target, scheme, rows=rows,
                                         log_offset_fraction=log_offset_fraction,
                                         value_column=value_column, sem_column=sem_column,
                                         executor=executor, fold_start=fold_start)
                if points.empty:
                    continue
                rows_out.append(_summarise_folds(points, method, target, scheme))
    return pd.DataFrame(rows_out)


def loo_predictions(table: pd.DataFrame, method: str, target: str | None = None,
                    scheme: str = "point", rows: str | None = None,
                    log_offset_fraction: float = DEFAULT_LOG_OFFSET_FRACTION,
                    value_column: str = VALUE_COLUMN, sem_column: str = SEM_COLUMN,
                    fit_rows: str | None = None, executor=None,
                    fold_start: str = "table") -> pd.DataFrame:
    """Every held-out row's prediction in one cross-validation scheme (see :func:`cross_validate`).

    ``rows`` chooses the rows that are held out in turn; ``fit_rows`` (default: ``rows``) the
    rows of the rest that each fold fits, so that a spline fitted to the status-ok rows can be
    scored on every case the fit policy keeps. A held-out row outside the fold's domain is left
    out (count them with ``n_predictions``).

    The folds are independent: an ``executor`` (:func:`fold_workers`) fits them in its worker
    processes; the result is the same.

    A ``gp`` fold refits the hyperparameters. With ``fold_start="table"`` (the default) its
    optimiser starts from those of the GP fitted to every row the folds draw on, without
    restarts: a fold lacks one point (or one plane) of that table, and its optimum lies near the
    whole table's. ``"restarts"`` fits each fold as :func:`fit_surrogate` fits a table, from the
    initial kernel and :data:`pidpipe.design.gaussian_process.RESTARTS` random ones, about three
    times the work (``benchmarks/bench_cross_validation.py`` compares the two).

    Returns
    -------
    pandas.DataFrame
        One row per held-out prediction: ``fold``, the coordinates, ``status`` and ``flags``
        (when the table has them), ``value``, ``sem`` (NaN without SEMs), ``predicted``, and for
        ``gp`` ``u`` (the prediction's standard uncertainty, value units, without the excess
        scatter), ``z`` (in the transformed target, see :func:`cross_validate`), ``in_68`` and
        ``in_95``. Empty when no fold can be fitted.
    """
    default_target, default_rows = METHOD_DEFAULTS[method]
    target = default_target if target is None else target
    rows = default_rows if rows is None else rows
    fit_rows = rows if fit_rows is None else fit_rows
    table = validate_ceq_table(table)
    if rows == "policy":
        used, _ = split_for_fit(table, value_column, sem_column)
    else:
        used, _ = split_usable(table)
    used = used.reset_index(drop=True)
    fit_options = {"method": method, "target": target, "rows": fit_rows,
                   "log_offset_fraction": log_offset_fraction,
                   "allow_holes": scheme == "point" or method in _BRIDGING_METHODS,
                   "value_column": value_column, "sem_column": sem_column}
    if fold_start not in FOLD_STARTS:
        raise ValueError(f"fold_start must be one of {FOLD_STARTS}, got {fold_start!r}")
    if method == "gp" and fold_start == "table":
        try:
            whole = fit_surrogate(used, **fit_options)
        except TableError:
            whole = None        # too little to fit: each fold then fails alike
        if whole is not None:
            fit_options["kernel_start"] = whole.options["kernel_theta"]
    jobs = [(fold, used.loc[~held], used.loc[held], fit_options)
            for fold, held in enumerate(_folds(used, scheme))]
    if executor is not None and len(jobs) > 1:
        frames = list(executor.map(_fold_predictions, jobs))
    else:
        frames = [_fold_predictions(job) for job in jobs]
    out = [frame for frame in frames if frame is not None]
    return pd.concat(out, ignore_index=True) if out else pd.DataFrame()


def _fold_predictions(job) -> pd.DataFrame | None:
    """One fold of :func:`loo_predictions`: fit the rest, predict the held-out rows inside the
    fold's domain (None when the fold cannot be fitted or holds none inside)."""
    fold, rest, test, fit_options = job
    method, value_column, sem_column = (fit_options["method"], fit_options["value_column"],
                                        fit_options["sem_column"])
    try:
        surrogate = fit_surrogate(rest, **fit_options)
    except TableError:
        return None  # this fold leaves too little to fit (e.g. an axis of one level)
    pts = test[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    inside = np.ones(len(test), dtype=bool)
    for i, name in enumerate(COORDINATE_COLUMNS):  # a held-out edge plane is outside
        lo, hi = surrogate.domain[name]
        inside &= (pts[:, i] >= lo) & (pts[:, i] <= hi)
    if not inside.any():
        return None
    test, pts = test.loc[inside], pts[inside]
    frame = test[[c for c in (*COORDINATE_COLUMNS, "status", "flags") if c in test.columns]].copy()
    frame.insert(0, "fold", fold)
    frame["value"] = test[value_column].to_numpy(dtype=float)
    frame["sem"] = (test[sem_column].to_numpy(dtype=float) if sem_column in test.columns
                    else np.nan)
    frame["predicted"] = surrogate._predict(*pts.T)
    if method == "gp":
        frame["u"] = surrogate.predict_with_uncertainty(*pts.T)[1]
        mu, sd = surrogate._model.predict(surrogate._model_input(*pts.T), include_white=True)
        y, noise = _to_target(frame["value"].to_numpy(), frame["sem"].to_numpy(),
                              surrogate.target, surrogate.offset_ns_m,
                              at=frame["predicted"].to_numpy())
        frame["z"] = (y - mu) / np.sqrt(sd**2 + noise)
        frame["in_68"] = np.abs(frame["z"]) <= 1.0
        frame["in_95"] = np.abs(frame["z"]) <= float(ndtri(0.975))
    return frame


def _folds(used: pd.DataFrame, scheme: str) -> list[np.ndarray]:
    """Boolean masks of the held-out rows, one per fold."""
    if scheme == "point":
        return [np.arange(len(used)) == i for i in range(len(used))]
    folds = []
    for name, levels in _levels(used).items():
        for level in levels[1:-1]:
            folds.append(used[name].to_numpy(dtype=float) == level)
    return folds


def _summarise_folds(points: pd.DataFrame, method: str, target: str, scheme: str) -> dict:
    """One row of :func:`cross_validate` from :func:`loo_predictions`' rows."""
    truth, predicted = points["value"].to_numpy(), points["predicted"].to_numpy()
    where = points[list(COORDINATE_COLUMNS)].to_numpy(dtype=float)
    error = np.abs(predicted - truth)
    floor = RELATIVE_ERROR_FLOOR * float(np.max(np.abs(truth)))
    relative = error / np.maximum(np.abs(truth), max(floor, 1e-300))
    worst = int(np.argmax(relative))
    sem = points["sem"].to_numpy(dtype=float)
    per_sem = (predicted - truth) / sem
    per_sem = per_sem[np.isfinite(per_sem)]
    row = {
        "method": method, "target": target, "scheme": scheme,
        "n_folds": int(points["fold"].nunique()), "n_predictions": int(truth.size),
        "rms_rel_error": float(np.sqrt(np.mean(relative**2))),
        "max_rel_error": float(relative[worst]),
        "rms_abs_error_ns_m": float(np.sqrt(np.mean(error**2))),
        "max_abs_error_ns_m": float(error.max()),
        "worst_freq_hz": float(where[worst, 0]), "worst_accel_g": float(where[worst, 1]),
        "worst_fill_pct": float(where[worst, 2]),
        "rms_error_per_sem": float(np.sqrt(np.mean(per_sem**2))) if per_sem.size else np.nan,
    }
    if "z" in points.columns:
        z = points["z"].to_numpy(dtype=float)
        row.update(z_mean=float(np.mean(z)), z_std=float(np.std(z, ddof=1)) if z.size > 1 else np.nan,
                   coverage_68=float(points["in_68"].mean()), coverage_95=float(points["in_95"].mean()))
    return row


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

