"""`filmcal doe`: an optimal Latin hypercube design written as CSV."""
from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

import numpy as np

from filmcal._validation import arg_int_in
from filmcal.commands._common import print_json
from filmcal.commands._options import add, bounds_text, local

if TYPE_CHECKING:
    from filmcal.doe import DesignSpace

# The default of OptimalLatinHypercube(n_outer=...), repeated here so that
# building the parser does not import scipy.stats and pyDOE.
ITERATIONS_DEFAULT = 30
# Bounds of the size options. The optimiser's time grows with samples x iterations
# (measured: 2000 points x 30 iterations in 4 dimensions about 25 s, 500 x 1000 about
# 7 min on one core) and its memory as samples^2.
MAX_SAMPLES = 2000
MAX_ITERATIONS = 1000
MAX_PARAMS = 20


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
    local(parser, "--samples", type=arg_int_in(1, MAX_SAMPLES), required=True, metavar="N",
          help="number of points (at least 2 for a new design); with --augment, the number of points to add"
               + bounds_text(1, MAX_SAMPLES, True))
    local(parser, "--param", action="append", required=True, metavar="SPEC",
                        help="a parameter, repeatable: name=low:high (linear range), "
                             "name=low:high:log (log scale, low > 0), name=v1,v2,... "
                             f"(discrete levels), name=value (fixed); at most {MAX_PARAMS}")
    local(parser, "--out", required=True, metavar="CSV",
                        help="file to write the design to")
    add(parser, "seed", default=0, extra="; the same seed gives the same design (default 0)")
    local(parser, "--augment", metavar="CSV",
                        help="existing design to extend by --samples points; its columns "
                             "must be the --param names. The output holds the existing "
                             "points first, unchanged")
    local(parser, "--iterations", type=arg_int_in(1, MAX_ITERATIONS), default=ITERATIONS_DEFAULT,
          metavar="K", help=f"outer iterations of the optimiser; time grows linearly (default {ITERATIONS_DEFAULT})"
                            + bounds_text(1, MAX_ITERATIONS, True))
    add(parser, "json", action="store_true",
                        help="print the quality metrics as one JSON object")
    parser.set_defaults(func=run)


def _existing_points(path: str, space: DesignSpace) -> np.ndarray:
    """Points of an existing design file with columns in the order of `space`."""
    from filmcal.doe import read_design_csv

    names, points = read_design_csv(path)
    if sorted(names) != sorted(space.names):
        raise ValueError(f"--augment {path}: columns {', '.join(names)} do not match the "
                         f"--param names {', '.join(space.names)}")
    points = points[:, [names.index(name) for name in space.names]]
    try:
        space.to_unit(points)
    except ValueError as exc:
        raise ValueError(f"--augment {path}: {exc}") from None
    return points


def run(args: argparse.Namespace) -> int:
    """Build the design, write it, report its quality."""
    from filmcal.doe import (DesignSpace, augment_design, latin_design, parse_parameter,
                             write_design_csv)

    if len(args.param) > MAX_PARAMS:
        raise ValueError(f"--param given {len(args.param)} times; at most {MAX_PARAMS} parameters")
    from filmcal._io import check_distinct_files

    check_distinct_files((args.augment, "--augment"), (args.out, "--out"))
    if not args.augment and args.samples < 2:
        raise ValueError(f"--samples must be at least 2 without --augment, got {args.samples}")
    try:
        space = DesignSpace(tuple(parse_parameter(spec) for spec in args.param))
    except ValueError as exc:
        raise ValueError(f"--param: {exc}") from None
    if args.augment:
        design = augment_design(space, _existing_points(args.augment, space), args.samples,
                                seed=args.seed, n_outer=args.iterations)
    else:
        design = latin_design(space, args.samples, seed=args.seed, n_outer=args.iterations)
    write_design_csv(args.out, space.names, design.points)  # whole or not at all
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
