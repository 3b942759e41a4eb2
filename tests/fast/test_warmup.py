"""Compiling ahead (lieint.warmup): the kernels a process compiles are on disk for the next one,
so first calls spread over processes (compile_in_processes) leave the caller nothing to compile;
``lieint warmup --jobs`` and the study of ``lieint compare`` use it."""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import textwrap

import pytest

import lieint
from lieint.warmup import compile_in_processes, usable_cpus

# A script run with an empty numba cache of its own: two kernels are compiled by a pool's
# processes, then this process runs the same calls and counts what it had to compile.
_COLD = textwrap.dedent(
    """
    import functools, json, os, sys
    import lieint
    from lieint.fast import _jit
    from lieint.warmup import compile_in_processes

    def run(method):
        top = lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0])
        y0 = top.initial_state(angular_velocity=[0.3, 1.0, 0.2])
        sol = lieint.integrate(top, y0, (0.0, 0.1), h=0.01, method=method)
        return os.getpid(), sol.stats.backend

    if __name__ == "__main__":
        methods = sys.argv[1].split(",")
        ran = compile_in_processes([functools.partial(run, m) for m in methods], jobs=2)
        before = _jit.compilations()
        here = [run(m) for m in methods]
        print(json.dumps({"children": ran, "parent": os.getpid(), "here": here,
                          "compiled_here": _jit.compilations() - before}))
    """
)


@pytest.mark.slow
def test_kernels_compiled_in_the_pools_processes_are_loaded_not_compiled_by_the_caller(tmp_path):
    script = tmp_path / "cold.py"
    script.write_text(_COLD)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "LIEINT_COMPILE_NOTICE": "0"}
    done = subprocess.run(
        [sys.executable, str(script), "rkmk4,rk4"], capture_output=True, text=True, env=env, timeout=600, check=False
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    children = {pid for pid, _ in out["children"]}
    assert out["parent"] not in children and len(out["children"]) == 2  # run elsewhere
    assert [backend for _, backend in out["children"]] == ["numba", "numba"]
    assert [backend for _, backend in out["here"]] == ["numba", "numba"]
    assert out["compiled_here"] == 0  # both kernels came from the disk cache the pool wrote
    assert any((tmp_path / "cache").rglob("*.nbc"))


def _fails():
    raise RuntimeError("planted")


def test_a_failing_task_gives_none_and_the_others_their_values():
    """A task is for its side effect; its failure is left to the caller's own call of the same
    thing, so it reads None and does not stop the others (in a pool and in this process)."""
    tasks = [os.getpid, _fails, functools.partial(int, "7")]
    for jobs in (1, 2):
        pid, failed, seven = compile_in_processes(tasks, jobs=jobs)
        assert failed is None and seven == 7
        assert (pid == os.getpid()) == (jobs == 1)  # one job: in this process


def test_a_process_that_dies_ends_the_pool_quietly():
    """A pool's process killed mid-task (here it exits at once) breaks the pool: what did not run
    reads None and nothing is raised, the caller then compiling as it would have anyway."""
    results = compile_in_processes([functools.partial(os._exit, 3), os.getpid], jobs=2)
    assert results[0] is None
    assert results[1] is None or results[1] != os.getpid()  # not run, or run in the pool
    assert compile_in_processes([os.getpid], jobs=2)[0] == os.getpid()  # one task: in this process


def test_finished_tasks_are_reported_with_their_index():
    seen = {}
    compile_in_processes([functools.partial(int, "1"), functools.partial(int, "2")], jobs=2, done=seen.__setitem__)
    assert seen == {0: 1, 1: 2}


@pytest.mark.parametrize("jobs", [0, -1, 1.5, "2", True])
def test_jobs_must_be_a_positive_integer(jobs):
    with pytest.raises(
        ValueError, match=r"`jobs` must be a positive integer .*; got " + repr(jobs).replace(".", r"\.")
    ):
        compile_in_processes([os.getpid], jobs=jobs)


def test_usable_cpus_is_at_most_the_machines_count():
    assert 1 <= usable_cpus() <= (os.cpu_count() or 1)


def test_a_study_on_a_warm_cache_starts_no_process():
    """Once the first compiled series finds its kernel cached, nothing is compiled ahead: no
    process is started for a study whose kernels are on disk (the suite has compiled these)."""
    from lieint.scenes import embedded_scene
    from lieint.study import run_study

    lieint.integrate(  # the first series' kernel, cached by now whatever ran before
        lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]),
        lieint.EulerTop.from_principal_moments([1.0, 2.0, 3.0]).initial_state(angular_velocity=[0.3, 1.0, 0.2]),
        (0.0, 0.1),
        h=0.01,
        method="rkmk4",
    )
    scene = embedded_scene("dzhanibekov")
    study = run_study(scene, methods=["rkmk4", "rk4"], repeats=1, max_seconds=0.5, compile_jobs=None)
    ahead = study.metadata["compiled_ahead"]
    assert ahead["series"] == 2 and ahead["processes"] == 0  # rkmk4 and rk4: two kernels
    assert {row.backend for row in study.rows} == {"numba"}
