"""The Gaussian process's own mean: the same bits as scikit-learn's prediction."""

import numpy as np

from pidpipe.design.gaussian_process import fit_gaussian_process


def _fitted(seed: int = 3):
    rng = np.random.default_rng(seed)
    x = rng.random((40, 3))
    y = np.sin(3.0 * x[:, 0]) + x[:, 1] ** 2 - 0.5 * x[:, 2] + 0.02 * rng.standard_normal(40)
    return fit_gaussian_process(x, y, np.full(40, 0.02**2)), rng


def test_the_mean_is_scikit_learns_bit_for_bit():
    model, rng = _fitted()
    for count in (1, 7, 500):
        x = rng.random((count, 3))
        expected = model.mean + model.scale * model.regressor.predict(x)
        np.testing.assert_array_equal(model(x), expected)
    # a model conditioned on other values with the same hyperparameters too
    refit = model.refit(model.y[::-1].copy(), model.noise)
    x = rng.random((20, 3))
    np.testing.assert_array_equal(refit(x), refit.mean + refit.scale * refit.regressor.predict(x))


def test_the_mean_follows_the_training_values():
    model, _ = _fitted()
    assert np.max(np.abs(model(model.x) - model.y)) < 0.1
    assert np.allclose(model.predict(model.x)[0], model(model.x), rtol=0, atol=1e-12)
