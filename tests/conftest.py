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


#: the method forms' families with stage code on every system form ("rkmk": exponential
#: coordinates with a truncated dexp⁻¹, or Cayley coordinates; "cf": products of exponentials, the
#: commutator-free and Crouch–Grossman methods; "rk": classical RK)
EVERY_FORM = ("rkmk", "cf", "rk")


def compiled_methods() -> list[str]:
    """The registry's fixed-step methods whose ``compiled()`` declares a form the compiled
    engine takes on every system form (:data:`EVERY_FORM`)."""
    import lieint

    names = []
    for name in lieint.method_names():
        method = lieint.get_method(name)
        form = method.compiled()
        if not method.adaptive and getattr(form, "family", None) in EVERY_FORM:
            names.append(name)
    return names


def fitted_slope(hs, errors):
    """Least-squares slope of log(error) against log(h)."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


# -- figures of the hard-case suite (tests/hard) -------------------------------------------
HARD_FIGURES: list[tuple[str, str, str, str]] = []


@pytest.fixture
def radius_spy(monkeypatch):
    """Every answer of a compiled kernel to the step check, as ``(the bound the kernel kept,
    what it answered)``, appended to the list this fixture returns."""
    from lieint.loops import _KernelLoop

    seen = []
    original = _KernelLoop.generator_radius

    def spy(self, states, limit=0.0):
        seen.append((self.kernel.radius_bound, original(self, states, limit)))
        return seen[-1][1]

    monkeypatch.setattr(_KernelLoop, "generator_radius", spy)
    return seen


@pytest.fixture
def record(request):
    """``record(figure, value, truth)``: keep a figure of a hard case for the summary table."""

    def _record(figure: str, value, truth: str = ""):
        text = f"{value:.3g}" if isinstance(value, (float, np.floating)) else str(value)
        # carried by the test's report, so that the summary has it when the tests run in worker
        # processes too (pytest-xdist sends the reports, not the workers' globals)
        request.node.user_properties.append(("hard_figure", (request.node.name, figure, text, truth)))
        print(f"[hard] {request.node.name}: {figure} = {text}   ({truth})")

    return _record


def pytest_runtest_logreport(report):
    if report.when == "call":
        HARD_FIGURES.extend(tuple(entry) for name, entry in report.user_properties if name == "hard_figure")


def pytest_terminal_summary(terminalreporter):
    if not HARD_FIGURES:
        return
    terminalreporter.section("hard cases: how close to the edge")
    for case, figure, value, truth in HARD_FIGURES:
        terminalreporter.write_line(f"{case:60.60s} {figure:45.45s} {value:>12s}  {truth}")
    import os

    path = os.environ.get("LIEINT_HARD_REPORT")
    if path:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write("| case | figure | value | checked against |\n|---|---|---|---|\n")
            for case, figure, value, truth in HARD_FIGURES:
                fh.write(f"| `{case}` | {figure} | {value} | {truth} |\n")


# -- run files ------------------------------------------------------------------------------
def read_all(path):
    """Every series and the root attributes of a run file, read whole."""
    import h5py

    with h5py.File(path, "r", swmr=True) as f:  # swmr: also readable right after a SIGKILL
        out = {"t": f["t"][()]}
        for group in ("states", "invariants", "outputs"):
            if group in f:
                out.update({f"{group}/{k}": v[()] for k, v in f[group].items()})
        return out, dict(f.attrs)


def assert_identical(a, b):
    """Two :func:`read_all` series equal bit for bit."""
    assert a.keys() == b.keys()
    for key in a:
        assert a[key].shape == b[key].shape, key
        assert np.array_equal(a[key], b[key]), key  # bit for bit


def assert_same_sweep(a, b):
    """Two opened sweep stores hold the same data variables, bit for bit (the chunk bookkeeping
    aside)."""
    names = [v for v in a.data_vars if not v.startswith("chunk_")]
    assert names and set(names) == {v for v in b.data_vars if not v.startswith("chunk_")}
    for name in names:
        assert np.array_equal(a[name].values, b[name].values, equal_nan=False), name


# -- scenes ---------------------------------------------------------------------------------
#: the Dzhanibekov top with each flip recorded as an event (its flip times are known exactly)
FLIPS = """
[scene]
name = "Dzhanibekov top, each flip recorded"

[body]
principal_moments = [1.0, 2.0, 3.0]

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.01, 1.0, 0.01]

[integrator]
method = "rkmk853"
step = 0.01
t_end = 60.0
rtol = 1e-13
atol = 1e-16
save_every = 20

[output]
quantities = ["energy"]

# w₂ = Ω[0, 2] (w = (Ω₂₁, Ω₀₂, Ω₁₀)) changes sign at each flip
[[events]]
name = "flip"
output = "angular_velocity"
component = [0, 2]
"""


# -- the order the test runner's processes take the files in -------------------------------------
def pytest_collection_modifyitems(config, items):
    """Files holding slow tests first, most slow tests first (order within a file kept).

    ``pytest -n auto --dist loadfile`` hands the files out in collection order, one at a time to
    whichever process is free: a long file taken last keeps one process busy while the other
    waits (the collection order is alphabetical, and two of the longest files sit near its end).
    Taking the long files first is the classic longest-first schedule; the count of ``slow``
    marks is the file's measured weight (a test is marked slow when it takes seconds with a warm
    cache, so that the fast tier keeps to two minutes on two cores).
    """
    weight: dict[str, int] = {}
    for item in items:
        weight[item.fspath.strpath] = weight.get(item.fspath.strpath, 0) + (item.get_closest_marker("slow") is not None)
    first = {path: i for i, path in enumerate(dict.fromkeys(item.fspath.strpath for item in items))}
    items.sort(key=lambda item: (-weight[item.fspath.strpath], first[item.fspath.strpath]))
