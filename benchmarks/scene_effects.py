"""What simulating only the declared effects saves: the same scene with and without the
outputs that force extra state (orientation, contact path), timed side by side in one run.

Run: ``python benchmarks/scene_effects.py`` (prints a table of CPU times and ratios; the
median of ``--repeats`` runs each, interleaved so that machine noise hits both alike).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time

from lieint.scenes import build_system, embedded_scenes, run_scene

CASES = [
    ("dzhanibekov", ("energy", "casimirs"), ("energy", "casimirs", "orientation")),
    ("lagrange_top", ("energy", "casimirs"), ("energy", "casimirs", "orientation")),
    ("chaplygin_ball", ("energy", "casimirs"), ("energy", "casimirs", "contact_path")),
    ("offset_ball", ("energy",), ("energy", "contact_path")),
]


def cpu_time(scene) -> float:
    t0 = time.process_time()
    run_scene(scene)
    return time.process_time() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--t-end", type=float, default=5.0, help="shorten every scene to this end time")
    args = parser.parse_args()
    scenes = embedded_scenes()
    print(f"{'scene':16s} {'lean state':28s} {'full state':28s} {'lean [s]':>9s} {'full [s]':>9s} {'full/lean':>9s}")
    for name, lean_out, full_out in CASES:
        base = dataclasses.replace(scenes[name], t_end=scenes[name].t_start + args.t_end)
        lean = dataclasses.replace(base, outputs=lean_out)
        full = dataclasses.replace(base, outputs=full_out)
        t_lean, t_full = [], []
        for _ in range(args.repeats):
            t_lean.append(cpu_time(lean))
            t_full.append(cpu_time(full))
        a, b = statistics.median(t_lean), statistics.median(t_full)
        fields_lean = ",".join(build_system(lean)[0].fields)
        fields_full = ",".join(build_system(full)[0].fields)
        print(f"{name:16s} {fields_lean:28s} {fields_full:28s} {a:9.3f} {b:9.3f} {b / a:9.2f}")


if __name__ == "__main__":
    main()
