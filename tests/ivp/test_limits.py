"""Resource bombs are refused at once, with a message that says how to raise the limit.

All cases run in one child process that reports each case's time and, at the end, its peak
resident memory: every refusal must come within 5 s and the whole process stay under 500 MB.
"""

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

BASE = """
[scene]
name = "bomb"

[body]
{body}

[support]
type = "fixed_point"

[initial]
{initial}

[integrator]
method = "rkmk4"
step = {step}
t_end = {t_end}

[output]
quantities = ["energy"]
{extra}
"""

TOP = "principal_moments = [1.0, 2.0, 3.0]"
W0 = "angular_velocity = [0.1, 1.0, 0.1]"


def scene(tmp_path, name, body=TOP, initial=W0, step="0.01", t_end="1.0", extra=""):
    path = tmp_path / f"{name}.toml"
    path.write_text(BASE.format(body=body, initial=initial, step=step, t_end=t_end, extra=extra))
    return str(path)


CHILD = textwrap.dedent(
    """
    import json, sys, time

    def peak_mb():
        # VmHWM: the peak resident set of this process's own address space. (ru_maxrss would
        # not do: Linux carries it over from the parent across fork and exec, so a child of a
        # large pytest process would report the parent's size.)
        with open("/proc/self/status") as status:
            line = next(line for line in status if line.startswith("VmHWM:"))
        return int(line.split()[1]) / 1024
    import lieint
    from lieint.cli import main

    cases = json.loads(sys.argv[1])
    results = {}
    for name, argv in cases.items():
        tic = time.monotonic()
        try:
            if argv[0].startswith("api-"):
                top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
                y0 = top.initial_state(angular_velocity=[0.1, 1.0, 0.1])
                if argv[0] == "api-h":
                    lieint.integrate(top, y0, (0.0, 10.0), h=1e-300)
                else:  # scipy's solvers save on the grid of h: 10^10 save times
                    lieint.integrate(top, y0, (0.0, 10.0), h=1e-9, method="scipy:RK45")
                message, code = "accepted", 0
            else:
                import contextlib, io
                err = io.StringIO()
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    code = main(argv)
                message = err.getvalue()
        except Exception as exc:
            message, code = f"{type(exc).__name__}: {exc}", -1
        results[name] = {
            "seconds": time.monotonic() - tic,
            "code": code,
            "message": message,
            "peak_mb_after": peak_mb(),
        }
    results["peak_mb"] = peak_mb()
    print(json.dumps(results))
    """
)


@pytest.fixture(scope="module")
def refusals(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bombs")
    deep = 100_000
    np.save(tmp / "huge.npy", np.zeros((2, 3)))
    raw = (tmp / "huge.npy").read_bytes()
    # forge the header: claim 10^12 members of 3 numbers (the file holds 6)
    forged = raw.replace(b"(2, 3)", b"(1000000000000, 3)".ljust(6 + 12)[:18])
    header_len = int.from_bytes(forged[8:10], "little") + len(forged) - len(raw)
    (tmp / "forged.npy").write_bytes(forged[:8] + header_len.to_bytes(2, "little") + forged[10:])
    np.savez(tmp / "members.npz", w=np.zeros((2, 3)))
    ens = '[ensemble]\nfile = "{}"'
    cases = {
        "nesting": ["run", scene(tmp, "deep", initial="angular_velocity = " + "[" * deep + "]" * deep)],
        "ensemble_count": ["run", scene(tmp, "count", extra="[ensemble]\ncount = 1000000000\nseed = 1\nspread = 0.1")],
        "dimension": [
            "run",
            scene(tmp, "dim", body="uniform = true\ndimension = 100000\nmass = 1.0\nradius = 1.0", initial=""),
        ],
        "tiny_step_huge_span": ["run", scene(tmp, "span", step="1e-300", t_end="1e300")],
        "api_h": ["api-h"],
        "api_scipy_save_grid": ["api-scipy"],
        "steps_1e12": ["run", scene(tmp, "steps", step="1e-6", t_end="1e6")],
        "steps_1e12_streamed": ["run", scene(tmp, "steps2", step="1e-6", t_end="1e6"), "--out", str(tmp / "x.h5")],
        "forged_npy": ["run", scene(tmp, "forged", extra=ens.format("forged.npy"))],
        "npz": ["run", scene(tmp, "npz", extra=ens.format("members.npz"))],
        "stdin_ensemble": ["run", scene(tmp, "stdin", extra=ens.format("/dev/stdin"))],
        "stdin_scene": ["run", "/dev/stdin"],
        "rows_in_memory": ["run", scene(tmp, "rows", step="1e-5", t_end="1e4")],
        "ensemble_memory": [
            "run",
            scene(
                tmp,
                "ensmem",
                body="mass_tensor = " + str(np.diag(np.arange(1.0, 25.0)).tolist()),
                initial="omega = " + str([[0.0] * 24] * 24),
                extra="[ensemble]\ncount = 1000000\nseed = 1\nspread = 0.1",
            ),
        ],
    }
    # sweeps: every size is checked before anything is allocated or any process started
    top10 = scene(tmp, "top10", t_end="10.0", extra="")
    top1000 = scene(tmp, "top1000", t_end="1000.0", extra="")
    out = ["--out", str(tmp / "s.zarr"), "--quiet"]
    m0 = "body.principal_moments[0]"
    cases.update(
        {
            "sweep_values": ["sweep", top10, "--vary", f"{m0}=1:1.8:1000000000", *out, "--scheduler", "synchronous"],
            "sweep_points": ["sweep", top10, "--vary", f"{m0}=1:1.8:100000",
                             "--vary", "initial.angular_velocity[2]=0:0.1:100000", *out, "--scheduler", "synchronous"],
            "sweep_chunk": ["sweep", top10, "--vary", f"{m0}=1:1.8:100000", "--chunk", "1000000000000", *out,
                            "--scheduler", "synchronous"],
            "sweep_members": ["sweep", top10, "--vary", f"{m0}=1:1.8:1000", "--ensemble", "1000000", "--spread",
                              "0.01", *out, "--scheduler", "synchronous"],
            "sweep_chunks": ["sweep", top10, "--vary", f"{m0}=1:1.8:200000", "--chunk", "1", *out,
                             "--scheduler", "synchronous"],
            "sweep_workers": ["sweep", top10, "--vary", f"{m0}=1:1.8:10", "--workers", "1000000", *out],
            "sweep_room": ["sweep", top1000, "--vary", f"{m0}=1:1.8:100", "--ensemble", "10000", "--spread", "0.01",
                           "--chunk", "10", *out, "--scheduler", "synchronous"],
        }
    )  # fmt: skip
    # stdin is a pipe that never ends: reading it would hang, refusing it does not
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, json.dumps(cases)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp,
    )
    try:
        out, err = child.communicate(timeout=120)
    finally:
        child.kill()
    assert child.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


EXPECTED = {
    "nesting": "nested too deeply",
    "ensemble_count": "the ensemble count is 1000000000, more than the limit 1000000 (to allow it, set the "
    "environment variable LIEINT_MAX_ENSEMBLE",
    "dimension": "the dimension n is 100000, more than the limit 256",
    "tiny_step_huge_span": "the number of steps (t1 - t0)/`h` = (1e+300 - 0)/1e-300 is inf, more than the limit",
    "api_h": "the number of steps (t1 - t0)/`h` = (10 - 0)/1e-300 is 1e+301, more than the limit 10000000000",
    "api_scipy_save_grid": "the memory of the 10000000002 save times of `h` = 1e-09, `save_every` = 1 (bytes)",
    "steps_1e12": "is 1e+12, more than the limit 10000000000 (to allow it, set the environment variable "
    "LIEINT_MAX_STEPS",
    "steps_1e12_streamed": "is 1e+12, more than the limit 10000000000",
    "forged_npy": "the number of members in the file is 1000000000000, more than the limit 1000000",
    "npz": "it is a .npz archive (several arrays); save one array with numpy.save to a .npy file",
    "stdin_ensemble": "not a regular file",
    "stdin_scene": "not a regular file",
    "ensemble_memory": "the memory of 1000000 initial omega (bytes) is 4608000000, more than the limit 4294967296",
    "rows_in_memory": "more than the limit 4294967296 (to allow it, set the environment variable LIEINT_MAX_MEMORY",
    "sweep_values": "--vary body.principal_moments[0]: the number of values NUM is 1000000000, more than the limit "
    "1000000 (to allow it, set the environment variable LIEINT_MAX_SWEEP_POINTS",
    "sweep_points": "the number of parameter points (the product of the values of body.principal_moments[0] (100000) "
    "× initial.angular_velocity[2] (100000)) is 10000000000, more than the limit 1000000",
    "sweep_chunk": "the memory of one chunk (100000 members × 1001 save times × 80 bytes, twice) (bytes) is "
    "16016000000, more than the limit 4294967296 (to allow it, set the environment variable LIEINT_MAX_MEMORY",
    "sweep_members": "the number of members (parameter points 1000 × --ensemble 1000000) is 1000000000, more than the "
    "limit 10000000 (to allow it, set the environment variable LIEINT_MAX_SWEEP_MEMBERS",
    "sweep_chunks": "the number of chunks (200000 members in chunks of --chunk 1) is 200000, more than the limit "
    "100000 (to allow it, set the environment variable LIEINT_MAX_SWEEP_CHUNKS",
    "sweep_workers": "--workers: the number of worker processes is 1000000, more than the limit",
    "sweep_room": "the sweep's store needs up to 8 TB (1000000 members × 100001 save times × 80 bytes) but only",
}


@pytest.mark.parametrize("case", sorted(EXPECTED))
@pytest.mark.slow
def test_each_bomb_is_refused_quickly_with_a_clear_message(refusals, case):
    result = refusals[case]
    assert result["seconds"] < 5, result
    assert "Traceback" not in result["message"]
    assert EXPECTED[case] in result["message"], result["message"]
    if case.startswith("api_"):
        assert result["message"].startswith("LimitError")  # a ValueError naming the argument
    else:
        assert result["code"] == 2, result
    if case.startswith("sweep_"):
        assert result["message"].count("\n") == 1, result["message"]  # one line
        assert "--" in result["message"] or "LIEINT_SKIP_ROOM_CHECK" in result["message"]  # the flag to change


def test_the_bombs_never_took_much_memory(refusals):
    peaks = {name: r["peak_mb_after"] for name, r in refusals.items() if isinstance(r, dict)}
    assert refusals["peak_mb"] < 500, peaks  # the peak after each case names the one that grew


def test_limits_are_raised_by_the_environment(monkeypatch):
    from lieint.limits import LimitError, check, limit

    assert limit("LIEINT_MAX_DIMENSION") == 256
    with pytest.raises(LimitError, match="LIEINT_MAX_DIMENSION=300"):
        check("LIEINT_MAX_DIMENSION", 300, "the dimension n")
    monkeypatch.setenv("LIEINT_MAX_DIMENSION", "512")
    check("LIEINT_MAX_DIMENSION", 300, "the dimension n")
    monkeypatch.setenv("LIEINT_MAX_DIMENSION", "lots")
    with pytest.raises(LimitError, match="LIEINT_MAX_DIMENSION must be a positive number; got 'lots'"):
        limit("LIEINT_MAX_DIMENSION")
    with pytest.raises(LimitError):
        check("LIEINT_MAX_STEPS", float("nan"), "the number of steps")


def _steps_chosen_by_error_control():
    """Every registry method whose steps are not a fixed grid, in each of its coordinate maps and
    back ends: the embedded pairs compiled ("auto") and generic ("numpy"), scipy's solvers."""
    from lieint.methods.registry import get_method, method_specs

    out = []
    for name, spec in method_specs().items():
        for coordinates in spec.coordinates or (None,):
            method = get_method(name, coordinates=coordinates)
            if method.adaptive:
                out += [(name, coordinates, "auto"), (name, coordinates, "numpy")]
            elif method.self_controlled:
                out.append((name, coordinates, "auto"))
    return out


@pytest.mark.parametrize(("name", "coordinates", "backend"), _steps_chosen_by_error_control())
@pytest.mark.slow
def test_an_adaptive_run_never_holds_more_rows_than_the_memory_limit(monkeypatch, name, coordinates, backend):
    # tolerances below round-off drive the steps down without end, every one saved: the run is
    # refused at the limit instead of exhausting the machine (24 GB were reached before)
    import lieint
    from lieint.limits import LimitError

    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0]))
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    row = 8 + 2 * 9 * 8  # t, A and R
    monkeypatch.setenv("LIEINT_MAX_MEMORY", str(40 * row))
    kw = dict(method=name, coordinates=coordinates, rtol=1e-10, atol=1e-12, backend=backend)
    with pytest.raises(LimitError, match=r"rows saved so far by an adaptive run .* LIEINT_MAX_MEMORY") as caught:
        lieint.integrate(top, y0, (0.0, 1000.0), **kw)  # every method takes more than 40 steps
    # refused at the first row beyond the limit, on every path (the compiled kernel is given no
    # more steps than fit: its buffer does not outgrow the limit either)
    assert "the memory of the 41 rows saved so far" in str(caught.value)
    assert "`rtol` = 1e-10, `atol` = 1e-12, `save_every` = 1" in str(caught.value)
    # the budget counts saved rows: a run of more steps than the limit's rows, saving every
    # 1000th step, fits
    sol = lieint.integrate(top, y0, (0.0, 20.0), save_every=1000, **kw)
    assert sol.success and sol.t[-1] == 20.0 and sol.t.size < 40 and sol.nsteps > 40


def test_the_row_budget_covers_t_eval_rows_of_scipy(monkeypatch):
    import lieint
    from lieint.limits import LimitError

    top = lieint.EulerTop(np.diag([1.0, 2.0, 3.0]))
    y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.4])
    monkeypatch.setenv("LIEINT_MAX_MEMORY", str(40 * (8 + 2 * 9 * 8)))
    with pytest.raises(LimitError, match="LIEINT_MAX_MEMORY"):
        lieint.integrate(top, y0, (0.0, 1.0), method="scipy:DOP853", t_eval=np.linspace(0.0, 1.0, 100))
    sol = lieint.integrate(top, y0, (0.0, 1.0), method="scipy:DOP853", t_eval=np.linspace(0.0, 1.0, 30))
    assert sol.t.size == 30
