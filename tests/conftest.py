"""Shared helpers: random bivectors and rotations, slope fitting."""

import numpy as np
import pytest


def random_skew(rng, n, batch=(), scale=1.0):
    X = rng.normal(size=(*batch, n, n))
    return scale * (X - np.swapaxes(X, -1, -2)) / 2


def random_rotation(rng, n, batch=()):
    Q, Rr = np.linalg.qr(rng.normal(size=(*batch, n, n)))
    Q = Q * np.sign(np.diagonal(Rr, axis1=-2, axis2=-1))[..., None, :]
    det = np.linalg.det(Q)
    Q[..., :, 0] *= np.sign(det)[..., None]
    return Q


def fitted_slope(hs, errors):
    """Least-squares slope of log(error) against log(h)."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
