"""Streamed run files: peak memory against the number of saved rows, write rate, and how long
``lieint info`` takes to verify every checksum.

Each run is a separate ``lieint run --out`` process (a 3D top on the compiled path, one row
saved per step); its peak resident memory comes from the kernel (``wait4``), so imports,
numba and HDF5 count as they would for a user. Memory should be flat in the number of rows:
the ratio of the largest run's peak to the smallest one's is printed.

Run: ``python benchmarks/run_files.py`` (10⁵ and 10⁶ rows; ``--full`` adds 3·10⁶).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENE = """
[scene]
name = "3D top, every step saved"

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
save_every = 1

[output]
quantities = ["energy", "casimirs", "orientation"]
"""


def measure(rows: int, directory: Path) -> dict:
    """Run ``lieint run`` saving ``rows`` rows; its peak RSS (MB), wall time and file size."""
    scene = directory / f"top{rows}.toml"
    scene.write_text(SCENE.format(t_end=(rows - 1) * 0.01))
    out = directory / f"top{rows}.h5"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    tic = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "lieint", "run", str(scene), "--out", str(out), "--quiet", "--overwrite"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - tic
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"lieint run failed: {proc.stderr.read().decode()}")
    tic = time.perf_counter()
    info = subprocess.run(
        [sys.executable, "-m", "lieint", "info", str(out), "--timeout", "600"], capture_output=True, text=True
    )
    info_wall = time.perf_counter() - tic
    if info.returncode != 0:
        raise RuntimeError(info.stdout + info.stderr)
    return {
        "rows": rows,
        "peak_mb": usage.ru_maxrss / 1024,  # kB on Linux
        "wall": wall,
        "size_mb": out.stat().st_size / 1e6,
        "info_wall": info_wall,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="also 3e6 rows")
    parser.add_argument("--rows", type=int, nargs="*", help="row counts to run (overrides the defaults)")
    args = parser.parse_args(argv)
    counts = args.rows or ([100_000, 1_000_000, 3_000_000] if args.full else [100_000, 1_000_000])
    with tempfile.TemporaryDirectory() as tmp:
        measure(1_000, Path(tmp))  # compile and cache the kernel outside the measurements
        results = [measure(n, Path(tmp)) for n in counts]
    print(
        f"{'rows':>10s}  {'peak RSS [MB]':>13s}  {'wall [s]':>8s}  {'rows/s':>10s}  {'file [MB]':>9s}  {'info [s]':>8s}"
    )
    for r in results:
        print(
            f"{r['rows']:>10d}  {r['peak_mb']:>13.1f}  {r['wall']:>8.2f}  {r['rows'] / r['wall']:>10.3g}  "
            f"{r['size_mb']:>9.1f}  {r['info_wall']:>8.2f}"
        )
    first, last = results[0], results[-1]
    print(
        f"peak memory at {last['rows']:.0e} rows / at {first['rows']:.0e} rows = "
        f"{last['peak_mb'] / first['peak_mb']:.3f} (flat: 1)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
