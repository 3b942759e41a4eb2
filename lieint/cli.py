"""The ``lieint`` command line: thin -- parse, build, call the library, print."""

from __future__ import annotations

import argparse
import sys

__all__ = ["main"]


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive finite number, got {text!r}")
    return value


def _build_parser() -> argparse.ArgumentParser:
    from .compare import DEFAULT_METHODS, DefaultScene

    scene = DefaultScene()
    parser = argparse.ArgumentParser(prog="lieint", description="Structure-preserving integrators for rigid bodies.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    cmp = sub.add_parser(
        "compare",
        help="compare integrators on the default scene (a 3D top near its unstable axis)",
        description=(
            "Integrate the embedded default scene -- an asymmetric top with principal moments "
            f"I = {scene.moments} started at body angular velocity w = {scene.angular_velocity}, "
            "close to the unstable middle axis -- with several methods, and print per method: "
            "step, steps, generator evaluations, CPU time, the largest relative error of the body "
            "momentum A against the exact Jacobi-elliptic solution, the relative energy and Casimir "
            "(spectrum of A) drifts, and the final orthogonality defect |R^T R - I|."
        ),
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    cmp.add_argument(
        "--methods", default=",".join(DEFAULT_METHODS), help="comma-separated method names (see `lieint methods`)"
    )
    cmp.add_argument(
        "--step", "-H", type=_positive_float, default=0.01, dest="h", help="step size h of the fixed-step methods"
    )
    cmp.add_argument("--t-end", type=_positive_float, default=scene.t_end, help="final time T")
    cmp.add_argument(
        "--coordinates", choices=("exp", "cayley"), default="exp", help="coordinate map of the Lie-group methods"
    )
    cmp.add_argument(
        "--no-project", action="store_true", help="do not project R onto SO(n) after each step (polar factor)"
    )
    cmp.add_argument("--rtol", type=_positive_float, default=1e-10, help="relative tolerance of scipy methods")
    cmp.add_argument("--atol", type=_positive_float, default=1e-12, help="absolute tolerance of scipy methods")
    cmp.add_argument("--format", choices=("table", "csv", "json"), default="table", help="output format")
    sub.add_parser(
        "methods",
        help="list the method names lieint.integrate accepts",
        description="List the method names lieint.integrate accepts.",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``lieint`` console script."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    if args.command == "methods":
        from .methods import methods

        print("\n".join(methods()))
        return 0
    if args.command == "compare":
        from .compare import format_rows, run_comparison
        from .methods import methods

        names = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = [m for m in names if m not in methods()]
        if unknown or not names:
            parser.error(f"--methods: unknown method(s) {unknown or names}; valid names are {methods()}")
        try:
            rows = run_comparison(
                names,
                h=args.h,
                t_end=args.t_end,
                coordinates=args.coordinates,
                project=not args.no_project,
                rtol=args.rtol,
                atol=args.atol,
            )
        except ValueError as exc:  # e.g. a step too large for the dexp⁻¹ series
            print(f"lieint compare: {exc}", file=sys.stderr)
            return 2
        if args.format == "table":
            print(
                f"Default scene: 3D top I = (1, 2, 3), w0 = (0.01, 1, 0.01), T = {args.t_end:g}, "
                f"projection {'off' if args.no_project else 'on'}; error = max_t |A - A_exact| / |A0|."
            )
        print(format_rows(rows, args.format))
        return 0
    parser.print_help()
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
