"""Scaling of a sweep from one to two dask workers on this machine, measured side by side.

The sweep: an asymmetric top near its unstable axis (compiled ensemble kernel), the first
principal moment varied over ``--points`` values, ``--ensemble`` initial states per value, for
``--t-end`` time units at h = 0.01 -- one chunk per value. Two LocalClusters (1 and 2 worker
processes, one thread each, numba and BLAS limited to it) are started first and warmed up; then
the same sweep runs on each, alternately, ``--repeats`` times, and the median wall times give

    efficiency = T(1 worker) / (2 · T(2 workers))      (1.0: perfect; the target is >= 0.8)

The machine's load average is printed before and after: on a shared machine other processes
take cores too, and the efficiency measures what this sweep got, not what the code could do.
Each worker's share of a core while it ran a chunk (chunk CPU time / chunk wall time) is printed
too; below 1 the worker waited for a core. The work itself is compared as the total CPU time of
the chunks (1 worker against 2: equal means distributing cost no extra work), and the client's
own time (planning, committing to the store) as wall time beyond the chunks.

Run: ``python benchmarks/sweep_scaling.py`` (about a minute on an idle 2-core machine), or
``--quick`` for a smaller sweep.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

SCENE = """
[scene]
name = "Top near its unstable axis"
[body]
principal_moments = [1.0, 2.0, 3.0]
[support]
type = "fixed_point"
[initial]
angular_velocity = [0.01, 1.0, 0.01]
[integrator]
method = "rkmk4"
step = 0.01
t_end = T_END
save_every = SAVE
[output]
quantities = ["energy", "casimirs"]
"""


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.2f} (1 min), {five:.2f} (5 min) on {os.cpu_count()} CPUs"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=16, help="values of the varied moment (one chunk each)")
    parser.add_argument("--ensemble", type=int, default=256, help="initial states per value")
    parser.add_argument("--t-end", type=float, default=1000.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="a sweep ten times smaller")
    args = parser.parse_args()
    if args.quick:
        args.t_end /= 10
    import distributed
    import xarray as xr

    from lieint.sweeps import sweep

    steps = round(args.t_end / 0.01)
    scene = SCENE.replace("T_END", repr(args.t_end)).replace("SAVE", str(max(1, steps // 10)))
    vary = {"body.principal_moments[0]": np.linspace(1.0, 1.6, args.points)}
    body_steps = args.points * args.ensemble * steps
    print(
        f"sweep: {args.points} values x {args.ensemble} tops x {steps} RKMK4 steps = {body_steps:.3g} body-steps, "
        f"{args.points} chunks"
    )
    print("before:", load())
    env = {k: "1" for k in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")}
    clusters = {
        k: distributed.LocalCluster(n_workers=k, threads_per_worker=1, processes=True, dashboard_address=":0", env=env)
        for k in (1, 2)
    }
    clients = {k: distributed.Client(c) for k, c in clusters.items()}
    work = Path(tempfile.mkdtemp(prefix="lieint-sweep-bench-"))
    try:
        small = SCENE.replace("T_END", "1.0").replace("SAVE", "10")
        for k, client in clients.items():  # warm up: import lieint and load the compiled kernels
            sweep(small, {"body.principal_moments[0]": [1.0, 1.1]}, ensemble=args.ensemble, spread=0.01,
                  out=work / f"warm{k}.zarr", scheduler=client, progress=False)  # fmt: skip
        times: dict[int, list[float]] = {1: [], 2: []}
        shares: dict[int, list[float]] = {1: [], 2: []}
        cpu_work: dict[int, list[float]] = {1: [], 2: []}
        for r in range(args.repeats):
            for k in (1, 2):
                out = work / f"sweep{k}-{r}.zarr"
                t0 = time.perf_counter()
                report = sweep(scene, vary, ensemble=args.ensemble, spread=0.01, seed=1, chunk=args.ensemble,
                               out=out, scheduler=clients[k], progress=False)  # fmt: skip
                times[k].append(time.perf_counter() - t0)
                assert report.computed == args.points and report.workers == k
                ds = xr.open_zarr(out)
                cpu, wall = (ds["chunk_stats"].sel(stat=s).values for s in ("cpu_time", "wall_time"))
                shares[k].extend((cpu / wall).tolist())
                cpu_work[k].append(float(cpu.sum()))
                print(f"  repeat {r + 1}: {k} worker(s) {times[k][-1]:7.2f} s   ({load()})")
        # the same bits whatever the number of workers
        a, b = (xr.open_zarr(work / f"sweep{k}-0.zarr") for k in (1, 2))
        identical = all(np.array_equal(a[v].values, b[v].values) for v in a.data_vars if not v.startswith("chunk_"))
    finally:
        for c in clients.values():
            c.close()
        for c in clusters.values():
            c.close()
        shutil.rmtree(work, ignore_errors=True)
    t1, t2 = statistics.median(times[1]), statistics.median(times[2])
    print("after: ", load())
    print(f"median wall time: 1 worker {t1:.2f} s, 2 workers {t2:.2f} s; speed-up {t1 / t2:.2f}")
    print(f"efficiency T1 / (2 T2) = {t1 / (2 * t2):.2f}   (target >= 0.80)")
    for k in (1, 2):
        print(
            f"core share of a worker while it ran a chunk ({k} worker(s)): median {statistics.median(shares[k]):.2f}, "
            f"min {min(shares[k]):.2f}"
        )
    w1, w2 = statistics.median(cpu_work[1]), statistics.median(cpu_work[2])
    print(f"CPU time of the chunks (the work): 1 worker {w1:.2f} s, 2 workers {w2:.2f} s (ratio {w2 / w1:.2f})")
    s1, s2 = statistics.median(shares[1]), statistics.median(shares[2])
    print(
        f"efficiency at equal core share, T1 s1 / (2 T2 s2) = {t1 * s1 / (2 * t2 * s2):.2f} (what the efficiency would "
        "be if each worker had got the same share of a core in both runs)"
    )
    print(f"throughput with 2 workers: {body_steps / t2:.3g} body-steps/s; results identical: {identical}")


if __name__ == "__main__":
    main()
