"""`filmcal doe`: an optimal Latin hypercube design written as CSV."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

import numpy as np

from filmcal.commands._common import print_json

if TYPE_CHECKING:
    from filmcal.doe import DesignSpace

# The default of OptimalLatinHypercube(n_outer=...), repeated here so that
# building the parser does not import scipy.stats and pyDOE.
ITERATIONS_DEFAULT = 30


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register the `doe` subcommand."""
    parser = subparsers.add_parser(
        "doe",
        help="optimal Latin hypercube design of experiments (CSV)",
        description="Build a space-filling design: a Latin hypercube at cell centres, "
                    "optimised by the enhanced stochastic evolutionary algorithm on the "
                    "Morris-Mitchell criterion phi_50, mapped to the named parameters and "
                    "written as CSV (one column per parameter, one row per point). Quality "
                    "metrics are computed in the unit cube.",
    )
    parser.add_argument("--samples", type=int, required=True, metavar="N",
                        help="number of points (at least 2); with --augment, the number "
                             "of points to add (at least 1)")
    parser.add_argument("--param", action="append", required=True, metavar="SPEC",
                        help="a parameter, repeatable: name=low:high (linear range), "
                             "name=low:high:log (log scale, low > 0), name=v1,v2,... "
                             "(discrete levels), name=value (fixed)")
    parser.add_argument("--out", required=True, metavar="CSV",
                        help="file to write the design to")
    parser.add_argument("--seed", type=int, default=0,
                        help="random seed; the same seed gives the same design (default 0)")
    parser.add_argument("--augment", metavar="CSV",
                        help="existing design to extend by --samples points; its columns "
                             "must be the --param names. The output holds the existing "
                             "points first, unchanged")
    parser.add_argument("--iterations", type=int, default=ITERATIONS_DEFAULT, metavar="K",
                        help="outer iterations of the optimiser; time grows linearly "
                             f"(default {ITERATIONS_DEFAULT})")
    parser.add_argument("--json", action="store_true",
                        help="print the quality metrics as one JSON object")
    parser.set_defaults(func=run)


def _existing_points(path: str, space: DesignSpace) -> np.ndarray:
    """Points of an existing design file with columns in the order of `space`."""
    from filmcal.doe import read_design_csv

    names, points = read_design_csv(path)
    if sorted(names) != sorted(space.names):
        raise ValueError(f"--augment {path}: columns {', '.join(names)} do not match the "
                         f"--param names {', '.join(space.names)}")
    return points[:, [names.index(name) for name in space.names]]


def run(args: argparse.Namespace) -> int:
    """Build the design, write it, report its quality."""
    from filmcal.doe import (DesignSpace, augment_design, latin_design, parse_parameter,
                             write_design_csv)

    space = DesignSpace(tuple(parse_parameter(spec) for spec in args.param))
    if args.augment:
        design = augment_design(space, _existing_points(args.augment, space), args.samples,
                                seed=args.seed, n_outer=args.iterations)
    else:
        design = latin_design(space, args.samples, seed=args.seed, n_outer=args.iterations)
    write_design_csv(args.out, space.names, design.points)
    quality = design.quality
    if args.json:
        print_json({**quality.as_dict(), "elapsed_s": design.elapsed_s,
                    "samples": len(design.points), "dimensions": space.d,
                    "parameters": list(space.names), "out": str(args.out)})
    else:
        print(f"wrote {len(design.points)} points x {len(space.names)} parameters to "
              f"{args.out}: min distance {quality.min_distance:.4f}, phi_50 "
              f"{quality.phi_p:.4f}, centred L2 {quality.centered_l2:.3g}, "
              f"Latin {'yes' if quality.latin else 'no'}")
    return 0
