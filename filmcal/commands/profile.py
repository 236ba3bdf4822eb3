"""`filmcal profile`: sample a standard wheel or rail profile (CSV, JSON summary, plot)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

import numpy as np

from filmcal._io import atomic_open, atomic_savefig
from filmcal._validation import check_range
from filmcal.commands._common import print_json
from filmcal.commands._options import add, local
from filmcal.wheelrail.profiles import (
    PROFILE_KINDS, PROFILE_NAMES, Profile, get_profile, load_profile_csv, profile_dimensions,
)


def add_parser(subparsers) -> None:
    """Register the `profile` subcommand."""
    parser = subparsers.add_parser(
        "profile",
        help="sample the S1002 wheel or the 60E1/60E2 rail profile",
        description="Sample a wheel or rail profile from its standard definition (S1002: "
                    "UIC 510-2 / EN 13715; 60E1, 60E2: EN 13674-1) in its own standard "
                    "coordinates: y lateral (wheel: from the tape circle, rail: from the "
                    "symmetry axis; positive towards the field side, the flange is at y < 0), "
                    "z out of the body towards the mating body (wheel: radially outwards "
                    "from the tread datum, flange tip at +28 mm; rail: upwards from the crown "
                    "top). Prints CSV y_mm,z_mm by default.",
    )
    parser.add_argument("name", help=f"profile name ({', '.join(PROFILE_NAMES)}) or a CSV file "
                                     "with columns y_mm,z_mm")
    local(parser, "--step-mm", type=float, default=0.5,
                        help="spacing of the points along the profile in mm (default 0.5)")
    local(parser, "--kind", choices=PROFILE_KINDS, default=None,
                        help="for a CSV file: whether it is a wheel or a rail profile (default rail)")
    fmt = parser.add_mutually_exclusive_group()
    local(fmt, "--csv", action="store_true",
                     help="print the points as CSV y_mm,z_mm on stdout (the default output)")
    add(fmt, "json", action="store_true",
                     help="print a JSON summary: name, kind, y-range, number of points, checked "
                          "dimensions and the largest mismatches at section joints")
    local(parser, "--out", metavar="FILE",
                        help="write the CSV points to FILE instead of stdout")
    local(parser, "--plot", metavar="FILE.png", help="draw the profile into a PNG file")
    parser.set_defaults(func=run)


def _load(name: str, kind: str | None) -> Profile:
    if name.lower().endswith(".csv"):
        return load_profile_csv(name, kind=kind or "rail")
    profile = get_profile(name)
    if kind is not None and kind != profile.kind:
        raise ValueError(f"--kind {kind}: {profile.name} is a {profile.kind} profile (--kind applies to a CSV file)")
    return profile


def write_points_csv(y_mm: np.ndarray, z_mm: np.ndarray, stream: TextIO) -> None:
    """Write points as CSV with header y_mm,z_mm (micrometre resolution)."""
    rows = "".join(f"{y:.6f},{z:.6f}\n" for y, z in zip(y_mm, z_mm))
    stream.write("y_mm,z_mm\n" + rows)


def plot_profile(profile: Profile, y_mm: np.ndarray, z_mm: np.ndarray, path: str | Path) -> None:
    """Draw the profile and its section joints to a PNG (matplotlib, Agg)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(y_mm, z_mm, "-", lw=1.2, color="tab:blue", label=profile.name)
    joints = np.array([s.y_start_mm for s in profile.sections[1:]])
    if joints.size:
        ax.plot(joints, profile.z(joints), "o", ms=3, color="tab:red", label="section joints")
    ax.set_aspect("equal")
    if profile.kind == "wheel":
        ax.invert_yaxis()
    ax.set_xlabel("y (mm), field side positive")
    ax.set_ylabel("z (mm)" + (", radially outwards (axis inverted)" if profile.kind == "wheel" else ", up"))
    ax.set_title(f"{profile.name} ({profile.kind})")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)
    atomic_savefig(fig, path, dpi=150)


def run(args: argparse.Namespace) -> int:
    """Sample the profile and write CSV / JSON / PNG as asked."""
    step = check_range("step_mm", args.step_mm, 1e-3, 50.0, low_open=False, high_open=False)
    profile = _load(args.name, args.kind)
    y, z = profile.points(step)
    if args.out:
        with atomic_open(args.out, "w", newline="") as fh:
            write_points_csv(y, z, fh)
    if args.plot:
        plot_profile(profile, y, z, args.plot)
    if args.json:
        joints = profile.joints()
        print_json({
            "name": profile.name,
            "kind": profile.kind,
            "y_range_mm": list(profile.y_range_mm),
            "n_points": int(y.size),
            "step_mm": step,
            "dimensions": profile_dimensions(profile),
            "max_joint_z_mismatch_mm": max((abs(j.z_mismatch_mm) for j in joints), default=0.0),
            "max_joint_slope_mismatch": max((abs(j.slope_mismatch) for j in joints), default=0.0),
            "source": profile.source,
            "out": args.out,
        })
    elif args.csv or not (args.out or args.plot):
        write_points_csv(y, z, sys.stdout)
    return 0
