"""Every group answers to the same calls (identity, multiply, inverse, exp, log, project, cay),
and the group axioms hold for each, for single elements and batches."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_skew

from lieint.groups import SE, SO
from lieint.groups.base import LieGroup
from lieint.groups.vector import ProductGroup, VectorSpace


def _spin(n):
    from lieint.ga.rotor_top import Spin

    return Spin(n)


#: label → (group factory, random algebra element factory (rng, batch) → X)
GROUPS = {
    "SO(3)": (lambda: SO(3), lambda rng, b: random_skew(rng, 3, b, 0.5)),
    "SO(5)": (lambda: SO(5), lambda rng, b: random_skew(rng, 5, b, 0.5)),
    "SE(3)": (lambda: SE(3), lambda rng, b: _se_algebra(rng, 3, b)),
    "SE(4)": (lambda: SE(4), lambda rng, b: _se_algebra(rng, 4, b)),
    "R^(3,)": (lambda: VectorSpace((3,)), lambda rng, b: rng.normal(size=(*b, 3))),
    "SO(3) x R^(3,)": (
        lambda: ProductGroup(SO(3), VectorSpace((3,))),
        lambda rng, b: (random_skew(rng, 3, b, 0.5), rng.normal(size=(*b, 3))),
    ),
    "Spin(3)": (lambda: _spin(3), lambda rng, b: random_skew(rng, 3, b, 0.5)),
    "Spin(4)": (lambda: _spin(4), lambda rng, b: random_skew(rng, 4, b, 0.5)),
    "rotors over SO(4)": (lambda: _cover(SO(4), 4), lambda rng, b: random_skew(rng, 4, b, 0.5)),
    "rotors over SE(3)": (lambda: _cover(SE(3), 3), lambda rng, b: _se_algebra(rng, 3, b)),
    "motors": (lambda: _motors(), lambda rng, b: _se_algebra(rng, 3, b)),
}


def _cover(base, n):
    from lieint.ga.spin import SpinCover

    return SpinCover(base, n)


def _motors():
    from lieint.ga.motor import MotorGroup

    return MotorGroup()


BATCHES = [(), (4,), (2, 3)]
SURFACE = ("identity", "multiply", "inverse", "exp", "log", "project", "cay", "dexpinv", "dcayinv", "lincomb")


def _se_algebra(rng, n, batch):
    X = np.zeros((*batch, n + 1, n + 1))
    X[..., :n, :n] = random_skew(rng, n, batch, 0.5)
    X[..., :n, n] = rng.normal(size=(*batch, n))
    return X


def close(a, b, tol=1e-12):
    if isinstance(a, tuple):
        return all(close(x, y, tol) for x, y in zip(a, b, strict=True))
    return np.allclose(a, b, atol=tol, rtol=0)


def shape_of(g):
    return tuple(np.shape(x) for x in g) if isinstance(g, tuple) else np.shape(g)


def every_group_class():
    """Every concrete LieGroup subclass the package defines (loaded modules included)."""
    import lieint.ga.motor
    import lieint.ga.rotor_top
    import lieint.ga.spin  # noqa: F401  (defines SpinCover)

    seen, todo = set(), [LieGroup]
    while todo:
        cls = todo.pop()
        for sub in cls.__subclasses__():
            if sub not in seen:
                seen.add(sub)
                todo.append(sub)
    return {c for c in seen if not getattr(c, "__abstractmethods__", None) and c.__module__.startswith("lieint.")}


def test_every_group_of_the_package_is_covered():
    covered = {type(make()) for make, _ in GROUPS.values()}
    missing = {c.__qualname__ for c in every_group_class() - covered}
    assert not missing, f"add these groups to GROUPS: {missing}"


@pytest.mark.parametrize("label", list(GROUPS))
def test_every_group_offers_the_whole_surface(label):
    group = GROUPS[label][0]()
    for name in SURFACE:
        assert callable(getattr(group, name, None)), f"{label} has no {name}"


@pytest.mark.parametrize("batch", BATCHES, ids=str)
@pytest.mark.parametrize("label", list(GROUPS))
def test_group_axioms(label, batch, rng):
    make, algebra = GROUPS[label]
    G = make()
    X, Y, Z = algebra(rng, batch), algebra(rng, batch), algebra(rng, batch)
    a, b, c = G.exp(X), G.exp(Y), G.exp(Z)
    e = G.identity(batch)
    assert shape_of(e) == shape_of(a)
    assert close(G.multiply(e, a), a) and close(G.multiply(a, e), a)
    assert close(G.multiply(a, G.inverse(a)), e) and close(G.multiply(G.inverse(a), a), e)
    assert close(G.multiply(G.multiply(a, b), c), G.multiply(a, G.multiply(b, c)))
    # exp of −X is the inverse; exp(sX) exp(tX) = exp((s + t)X) (one-parameter subgroup)
    assert close(G.exp(G.negate(X)), G.inverse(a))
    assert close(G.multiply(G.exp(G.lincomb([0.3], [X])), G.exp(G.lincomb([0.7], [X]))), a)
    # log inverts exp near the identity; exp(0) = e
    assert close(G.log(a), X, 1e-11)
    assert close(G.exp(G.lincomb([0.0], [X])), e)
    # projection keeps group elements and pulls perturbed ones back
    assert close(G.project(a), a)
    assert close(G.project(G.project(a)), G.project(a))
    # the Cayley map, where a group has one, also lands in the group: cay(X) cay(−X) = e
    try:
        ca = G.cay(X)
    except ValueError:
        return  # a representation without a Cayley map says so
    assert close(G.multiply(ca, G.cay(G.negate(X))), e)


@pytest.mark.parametrize("label", [k for k in GROUPS if k.startswith(("SO", "SE", "Spin")) and " x " not in k])
def test_projection_removes_drift_off_the_group(label, rng):
    make, algebra = GROUPS[label]
    G = make()
    a = G.exp(algebra(rng, (5,)))
    noisy = a + 1e-6 * rng.normal(size=a.shape)
    if label.startswith("SE"):
        noisy[..., -1, :] = a[..., -1, :]  # the affine row is structure, not state
    p = G.project(noisy)
    assert np.abs(p - a).max() < 1e-5  # close to where it was …
    assert close(G.project(p), p)  # … and on the group: projecting again changes nothing
