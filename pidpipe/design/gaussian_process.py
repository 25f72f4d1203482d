"""A Gaussian-process regression with a known noise per training point (scikit-learn).

The surrogate (:mod:`pidpipe.design.surrogate`, method ``gp``) hands this module points ``x``
already scaled to [0, 1] per axis and values ``y`` already transformed (e.g. asinh of C_eq),
with each value's noise variance in the same units. The model is

    y(x) = m + s * g(x),     g ~ GP(0, k),
    k(x, x') = c * Matern_5/2(x, x'; l_1, l_2, l_3) + w * [x == x'],

observed as y_i + e_i with e_i ~ N(0, noise_i), noise_i given (scikit-learn's per-sample
``alpha``), or with e ~ N(0, Noise) for a full noise covariance given (cases whose errors are
correlated because they share packings, :mod:`pidpipe.design.packing_noise`): scikit-learn
takes only a diagonal, so that model's marginal likelihood and posterior are computed here
(:class:`CorrelatedNoiseRegressor`), with the same kernel, bounds, restarts and seed. m and s
are the mean and the standard deviation of the training values (so the kernel's hyperparameters are of order one whatever the units). The amplitude c, the three length
scales l (anisotropic: f, G and r vary on different scales) and the excess white noise w (scatter
the reported SEMs do not hold, e.g. between packings, fitted from the data and possibly ~0) are
fitted by maximising the marginal likelihood from a fixed set of restarts (``random_state``
fixed: the same table gives the same fit). The fit's linear algebra runs on one thread: the matrices
are ~60 x 60, and on a shared 2-core machine BLAS threads made a fit 6x slower (17.7 s
against 2.8 s).

Matern 5/2 rather than the squared exponential: its samples are twice differentiable, not
infinitely, which suits a response with a steep onset (C_eq just above 1 g) without forcing the
short length scale everywhere.

:meth:`GaussianProcess.predict` gives the posterior mean and the standard deviation of the
latent function y(x) (without w and without any e_i: what an infinitely long DEM case would
give), and, with ``include_white=True``, with the excess scatter w added (what one more DEM
case of the same kind would scatter about). A model rebuilt with :meth:`from_dict` reuses the
fitted hyperparameters (``optimizer=None``) and predicts identically.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.linalg import cho_solve, cholesky, solve_triangular
from scipy.optimize import minimize
from scipy.spatial.distance import cdist
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
from threadpoolctl import threadpool_limits

#: Restarts of the marginal-likelihood optimiser besides the initial kernel (from random
#: hyperparameters within the bounds).
RESTARTS = 4
#: Seed of the restarts (fixed: a fit is reproducible).
SEED = 0
#: Bounds of the hyperparameters, in the scaled units (x in [0, 1], y standardised).
AMPLITUDE_BOUNDS = (1e-3, 1e2)
LENGTH_SCALE_BOUNDS = (0.05, 20.0)
WHITE_BOUNDS = (1e-8, 1.0)


def _kernel(length_scale=(0.5, 0.5, 0.5), amplitude=1.0, white=1e-3):
    """c * Matern_5/2(l) + w, with the bounds of this module."""
    return (ConstantKernel(amplitude, AMPLITUDE_BOUNDS)
            * Matern(length_scale=np.asarray(length_scale, dtype=float),
                     length_scale_bounds=LENGTH_SCALE_BOUNDS, nu=2.5)
            + WhiteKernel(white, WHITE_BOUNDS))


@dataclass
class GaussianProcess:
    """A fitted GP over scaled points; build it with :func:`fit_gaussian_process`.

    Attributes
    ----------
    x : numpy.ndarray, shape (n, d)
        Training points (scaled).
    y : numpy.ndarray, shape (n,)
        Training values (transformed units).
    noise : numpy.ndarray, shape (n,) or (n, n)
        Noise variance of each training value, or their covariance, transformed units squared.
    theta : numpy.ndarray
        The fitted kernel's log-hyperparameters (scikit-learn's ``kernel_.theta``):
        ln c, ln l_1 .. ln l_d, ln w.
    mean, scale : float
        m and s of the module docstring.
    """

    x: np.ndarray
    y: np.ndarray
    noise: np.ndarray
    theta: np.ndarray
    mean: float
    scale: float
    regressor: "GaussianProcessRegressor | CorrelatedNoiseRegressor"

    @property
    def white(self) -> float:
        """Excess white-noise variance w, transformed units squared."""
        return float(np.exp(self.theta[-1])) * self.scale**2

    @property
    def length_scales(self) -> np.ndarray:
        """Fitted length scales, scaled-x units, shape (d,)."""
        return np.exp(self.theta[1:-1])

    def predict(self, x: np.ndarray, include_white: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation at m points.

        Parameters
        ----------
        x : numpy.ndarray, shape (m, d)
            Scaled query points.
        include_white : bool
            Add the excess scatter w to the variance (a new observation's spread without its
            own reported noise).

        Returns
        -------
        mean, sd : numpy.ndarray, shape (m,)
            Transformed units.
        """
        mean, sd = self.regressor.predict(np.asarray(x, dtype=float), return_std=True)
        white = float(np.exp(self.theta[-1]))
        var = np.maximum(sd**2 - white, 0.0)  # scikit-learn's std holds w: take it out
        if include_white:
            var = var + white
        return self.mean + self.scale * mean, self.scale * np.sqrt(var)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Posterior mean only, shape (m,) (the interface of the spline models).

        The same operations as scikit-learn's ``predict`` of the mean (c * Matern_5/2 between
        the query and the training points, times the fitted weights; the white kernel adds
        zeros), in the same order, so the same bits, without its checks of the input, which
        took half the time of the optimiser's many one-point calls."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        amplitude, length_scale, weights, training = self._mean_terms
        scaled = cdist(x / length_scale, training, metric="euclidean")
        k = scaled * math.sqrt(5)
        k = (1.0 + k + k**2 / 3.0) * np.exp(-k)
        mean = (np.full(k.shape, amplitude) * k) @ weights
        mean = self.regressor._y_train_std * mean + self.regressor._y_train_mean
        return self.mean + self.scale * mean

    @cached_property
    def _mean_terms(self) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """The fitted kernel's amplitude c and length scales, the weights (alpha_), and the
        training points divided by the length scales."""
        product = self.regressor.kernel_.k1
        length_scale = np.asarray(product.k2.length_scale, dtype=float)
        return (float(product.k1.constant_value), length_scale, self.regressor.alpha_,
                self.regressor.X_train_ / length_scale)

    def refit(self, y: np.ndarray, noise: np.ndarray) -> "GaussianProcess":
        """The same points and hyperparameters conditioned on new values (no optimisation)."""
        return fit_gaussian_process(self.x, y, noise, theta=self.theta)

    def to_dict(self) -> dict:
        """What :func:`fit_gaussian_process` needs to rebuild this model exactly."""
        return {"theta": self.theta.tolist(), "kernel": str(self.regressor.kernel_)}


def fit_gaussian_process(x, y, noise, theta=None, start=None) -> GaussianProcess:
    """Fit (or, given ``theta``, only condition) the GP of the module docstring.

    Parameters
    ----------
    x : array_like, shape (n, d)
        Scaled training points.
    y : array_like, shape (n,)
        Training values (transformed units).
    noise : array_like, shape (n,) or (n, n)
        Noise variance of each value (transformed units squared), >= 0, or the values' noise
        covariance (symmetric, positive semi-definite).
    theta : array_like, optional
        Log-hyperparameters of a previous fit (:attr:`GaussianProcess.theta`); the kernel is then
        fixed (``optimizer=None``) and the model is rebuilt deterministically.
    start : array_like, optional
        Log-hyperparameters to start the optimiser from, without restarts (a refit on slightly
        changed noise, whose optimum lies near the previous one).

    Returns
    -------
    GaussianProcess
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    noise = np.asarray(noise, dtype=float)
    mean = float(np.mean(y))
    scale = float(np.std(y))
    if not np.isfinite(scale) or scale <= 0.0:
        scale = 1.0
    standard = (y - mean) / scale
    jitter = 1e-10 * np.eye(len(noise)) if noise.ndim == 2 else 1e-10  # scikit-learn's default
    alpha = noise / scale**2 + jitter
    regressor_class = CorrelatedNoiseRegressor if noise.ndim == 2 else GaussianProcessRegressor
    if theta is None:
        kernel = _kernel(length_scale=np.full(x.shape[1], 0.5))
        if start is not None:
            kernel = kernel.clone_with_theta(np.asarray(start, dtype=float))
        regressor = regressor_class(
            kernel=kernel, alpha=alpha, n_restarts_optimizer=RESTARTS if start is None else 0,
            random_state=SEED)
        with warnings.catch_warnings(), threadpool_limits(1):
            # a hyperparameter at its bound (w -> 0 when the SEMs explain the scatter) is a
            # result, not a failure
            warnings.simplefilter("ignore", ConvergenceWarning)
            regressor.fit(x, standard)
        theta = regressor.kernel_.theta
    else:
        theta = np.asarray(theta, dtype=float)
        kernel = _kernel(length_scale=np.ones(x.shape[1])).clone_with_theta(theta)
        regressor = regressor_class(kernel=kernel, alpha=alpha, optimizer=None)
        with threadpool_limits(1):
            regressor.fit(x, standard)
    return GaussianProcess(x=x, y=y, noise=noise, theta=np.asarray(theta, dtype=float).copy(),
                           mean=mean, scale=scale, regressor=regressor)


class CorrelatedNoiseRegressor:
    """GP regression with a full noise covariance: scikit-learn's ``GaussianProcessRegressor``
    for the parts this module uses, with ``alpha`` an (n, n) matrix added to the kernel's.

    The log marginal likelihood of y ~ N(0, K(theta) + alpha) and its gradient in the kernel's
    log-hyperparameters (scikit-learn's kernels give dK/dtheta), maximised by L-BFGS-B within
    the kernel's bounds from its initial theta and ``n_restarts_optimizer`` starts drawn
    uniformly in the log-bounds (``random_state``), as scikit-learn does; ``optimizer=None``
    keeps the kernel. The attributes ``kernel_``, ``X_train_``, ``alpha_`` (the weights),
    ``L_``, ``_y_train_mean`` (0) and ``_y_train_std`` (1) mean what scikit-learn's do.
    """

    _y_train_mean = 0.0
    _y_train_std = 1.0

    def __init__(self, kernel, alpha: np.ndarray, optimizer: str | None = "fmin_l_bfgs_b",
                 n_restarts_optimizer: int = 0, random_state: int = 0):
        self.kernel = kernel
        self.alpha = np.asarray(alpha, dtype=float)
        self.optimizer = optimizer
        self.n_restarts_optimizer = int(n_restarts_optimizer)
        self.random_state = random_state

    def log_marginal_likelihood(self, theta: np.ndarray, eval_gradient: bool = False):
        """ln p(y | theta) (and its gradient in theta); -inf where K + alpha is not positive definite."""
        kernel = self.kernel.clone_with_theta(theta)
        if eval_gradient:
            k, k_gradient = kernel(self.X_train_, eval_gradient=True)
        else:
            k = kernel(self.X_train_)
        try:
            lower = cholesky(k + self.alpha, lower=True)
        except np.linalg.LinAlgError:
            return (-np.inf, np.zeros_like(theta)) if eval_gradient else -np.inf
        weights = cho_solve((lower, True), self.y_train_)
        value = (-0.5 * self.y_train_ @ weights - np.log(np.diag(lower)).sum()
                 - 0.5 * len(self.y_train_) * np.log(2 * np.pi))
        if not eval_gradient:
            return value
        inner = np.outer(weights, weights) - cho_solve((lower, True), np.eye(len(weights)))
        return value, 0.5 * np.einsum("ij,jik->k", inner, k_gradient)

    def fit(self, x: np.ndarray, y: np.ndarray) -> "CorrelatedNoiseRegressor":
        """Fit the kernel (unless ``optimizer`` is None) and condition on (x, y)."""
        self.X_train_ = np.asarray(x, dtype=float)
        self.y_train_ = np.asarray(y, dtype=float)
        self.kernel_ = self.kernel.clone_with_theta(self.kernel.theta)
        if self.optimizer is not None:
            bounds = self.kernel_.bounds
            starts = [self.kernel_.theta]
            rng = np.random.RandomState(self.random_state)
            starts += [rng.uniform(bounds[:, 0], bounds[:, 1])
                       for _ in range(self.n_restarts_optimizer)]
            best = None
            for start in starts:
                result = minimize(lambda t: tuple(-v for v in self.log_marginal_likelihood(t, True)),
                                  start, jac=True, method="L-BFGS-B", bounds=bounds)
                if np.isfinite(result.fun) and (best is None or result.fun < best.fun):
                    best = result
            if best is not None:
                self.kernel_ = self.kernel_.clone_with_theta(best.x)
        k = self.kernel_(self.X_train_)
        self.L_ = cholesky(k + self.alpha, lower=True)
        self.alpha_ = cho_solve((self.L_, True), self.y_train_)
        return self

    def predict(self, x: np.ndarray, return_std: bool = False):
        """Posterior mean (and standard deviation, the kernel's white part included, as
        scikit-learn's) at the rows of ``x``."""
        k_trans = self.kernel_(np.asarray(x, dtype=float), self.X_train_)
        mean = k_trans @ self.alpha_
        if not return_std:
            return mean
        v = solve_triangular(self.L_, k_trans.T, lower=True)
        var = self.kernel_.diag(np.asarray(x, dtype=float)) - np.einsum("ij,ij->j", v, v)
        return mean, np.sqrt(np.maximum(var, 0.0))
