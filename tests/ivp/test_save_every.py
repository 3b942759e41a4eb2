"""Every ``save_every`` on every back end saves exactly the rows of the unthinned run, bit for bit."""

import itertools

import h5py
import numpy as np
import pytest

import lieint
from lieint.control import Plan

TOP3 = """
[scene]
name = "3D top"

[body]
principal_moments = [1.0, 2.0, 3.0]

[support]
type = "fixed_point"

[initial]
angular_velocity = [0.01, 1.0, 0.01]

[integrator]
method = "rkmk4"
step = 0.01
t_end = {t_end}
save_every = {every}
{extra}

[output]
quantities = ["energy", "orientation"]
"""

N_STEPS = 120_007  # > 1e5, and not a multiple of any stride below: the last row is the odd one


def expected_rows(n: int, every: int) -> np.ndarray:
    """Indices into the every-step reference of what a run saving every ``every`` steps holds."""
    rows = np.arange(0, n + 1, every)
    return rows if rows[-1] == n else np.append(rows, n)


@pytest.fixture(scope="module")
def top3():
    top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
    return top, top.initial_state(angular_velocity=[0.01, 1.0, 0.01])


@pytest.fixture(scope="module")
def reference(top3):
    top, y0 = top3
    sol = lieint.integrate(top, y0, (0.0, N_STEPS * 0.01), h=0.01, method="rkmk4")
    assert sol.stats.backend == "numba" and sol.t.size == N_STEPS + 1
    return sol


@pytest.mark.parametrize("every", [1, 7, 1000, 100_000])
def test_compiled_path_in_memory(top3, reference, every):
    top, y0 = top3
    sol = lieint.integrate(top, y0, (0.0, N_STEPS * 0.01), h=0.01, method="rkmk4", save_every=every)
    rows = expected_rows(N_STEPS, every)
    assert sol.stats.backend == "numba" and np.array_equal(sol.t, reference.t[rows])
    for name in ("A", "R"):
        assert np.array_equal(sol.states[name], reference.states[name][rows]), name


@pytest.mark.parametrize("every", [1, 7, 1000, 100_000])
def test_compiled_path_streamed_in_segments(tmp_path, reference, every):
    """Segments of a streamed run mostly save nothing when ``every`` is large (the empty-segment case)."""
    path = tmp_path / "top.toml"
    path.write_text(TOP3.format(t_end=N_STEPS * 0.01, every=every, extra=""))
    report = lieint.run(path, tmp_path / "top.h5", progress=False, checkpoint_every=10_007)
    assert report.status == "complete", report.message
    rows = expected_rows(N_STEPS, every)
    with h5py.File(tmp_path / "top.h5") as f:
        assert f.attrs["backend"] == "numba"
        assert np.array_equal(f["t"][()], reference.t[rows])
        assert np.array_equal(f["states/A"][()], reference.states["A"][rows])
        assert np.array_equal(f["states/R"][()], reference.states["R"][rows])


@pytest.mark.parametrize(
    "extra, backend",
    [
        ('method = "lie_midpoint"\nbackend = "numpy"', "numpy"),
        ("", "lie"),
        ('method = "rk4"', "lie"),
        ("", "lanes"),
        ("", "topn"),
    ],
    ids=["generic-lie-midpoint", "lie-kernel-rkmk4", "lie-kernel-rk4", "compiled-ensemble-lanes", "compiled-4d-top"],
)
@pytest.mark.parametrize("every", [1, 7, 1000])
@pytest.mark.slow
def test_every_back_end_streamed(tmp_path, every, extra, backend):
    """The generic path (the scene asks for it), the generic compiled kernel
    (a 4D heavy top), the SIMD lanes of ensembles and the compiled n-dimensional top (a 4D free
    top)."""
    n = 1_003
    if backend == "lanes":
        text = TOP3.format(t_end=n * 0.01, every=every, extra="").replace(
            "[integrator]", "[ensemble]\ncount = 64\nseed = 1\nspread = 0.01\n\n[integrator]"
        )
    else:  # a 4D body: a free top, or under gravity a heavy top
        body = "mass_tensor = [[0.5, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.7, 0], [0, 0, 0, 2.3]]"
        if backend != "topn":
            body += "\nmass = 1.0\ncenter_of_mass = [0.0, 0.0, 0.1, 0.0]\n\n[forces]\ngravity = [0.0, 0.0, 0.0, -1.0]"
        text = TOP3.format(t_end=n * 0.01, every=every, extra="").replace("principal_moments = [1.0, 2.0, 3.0]", body)
        text = text.replace(
            "angular_velocity = [0.01, 1.0, 0.01]",
            "omega = [[0, -0.3, 0.5, -0.2], [0.3, 0, -0.4, 0.6], [-0.5, 0.4, 0, -0.1], [0.2, -0.6, 0.1, 0]]",
        )
        if extra.startswith("method"):
            text = text.replace('method = "rkmk4"', extra)
        elif extra:
            text = text.replace('method = "rkmk4"', f'method = "rkmk4"\n{extra}')
    full, thin = tmp_path / "full.toml", tmp_path / "thin.toml"
    full.write_text(text.replace(f"save_every = {every}", "save_every = 1"))
    thin.write_text(text)
    for scene, out in ((full, "full.h5"), (thin, "thin.h5")):
        report = lieint.run(scene, tmp_path / out, progress=False, checkpoint_every=97)
        assert report.status == "complete", report.message
    rows = expected_rows(n, every)
    with h5py.File(tmp_path / "full.h5") as a, h5py.File(tmp_path / "thin.h5") as b:
        if backend == "lanes":
            assert b.attrs["backend"] == "numba" and b["states/A"].shape[1] == 64
        elif backend in ("topn", "lie"):
            assert b.attrs["backend"] == "numba" and b["states/A"].shape[1:] == (4, 4)
        else:
            assert b.attrs["backend"] == "numpy"
        for name in ("t", "states/A", "states/R"):
            assert np.array_equal(b[name][()], a[name][()][rows]), name


def test_saves_between_is_save_steps_cut_into_segments():
    plan = Plan.make(0.0, 10.37, 0.01)
    for every in (1, 3, 7, 100, 1037, 5000):
        whole = plan.save_steps(every)[1:]
        cuts = [0, 1, 5, 99, 100, 101, 555, 1036, 1037]
        parts = [plan.saves_between(every, a, b) for a, b in itertools.pairwise(cuts)]
        assert np.array_equal(np.concatenate(parts), whole), every


def test_the_times_of_a_few_steps_and_of_many_are_each_steps_time_bit_for_bit():
    # a few steps are computed in Python floats, many in numpy: both must be Plan.time's values
    for t0, t1, h in ((0.0, 10.37, 0.01), (0.3, -7.1, -0.07), (1e6, 1e6 + 1.0, 1e-3)):
        plan = Plan.make(t0, t1, h)
        for steps in (np.array([plan.nsteps]), np.arange(0, plan.nsteps + 1, 7), np.arange(5), np.arange(16),
                      np.arange(17), np.zeros(0, dtype=np.int64)):  # fmt: skip
            expected = np.array([plan.time(int(k)) for k in steps], dtype=float)
            got = plan.times(steps)
            assert got.dtype == np.float64 and np.array_equal(got, expected), (t0, steps.size)
            np.testing.assert_array_equal(plan.times(steps, first=-2.5), np.concatenate([[-2.5], expected]))
