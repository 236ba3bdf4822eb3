"""`filmcal serve`: a study's correctors served to other tools by the UM-Bridge protocol."""
from __future__ import annotations

import argparse
import ipaddress
import sys

from filmcal.commands._options import add, local


def add_parser(subparsers) -> None:
    """Register the `serve` subcommand."""
    p = subparsers.add_parser(
        "serve",
        help="serve the study's correctors over HTTP (UM-Bridge protocol 1.0)",
        description="Serve the study's correctors to other tools (a vehicle-dynamics script, a notebook in "
                    "another language, a test rig) as a UM-Bridge server, protocol 1.0: the umbridge clients in "
                    "Python, C++, MATLAB and R, or a plain HTTP POST of JSON. Models: correct-sphere, input "
                    "[[measured_radius_mm, sphere_radius_mm, force_kn]], and correct-wheelrail, input "
                    "[[measured_area_mm2, offset_mm, force_kn]]; output [[area_mm2, area_std_mm2, "
                    "area_ci90_low_mm2, area_ci90_high_mm2]], the numbers `filmcal correct` prints. The film and "
                    "options go in the request's config: {\"film\": \"HS\"} and any of imprint_model, kinematics, "
                    "calibration_forces_kn, seed, elastic_limit_mpa, measurement_std_mm (sphere), "
                    "measured_area_std_mm2, offset_std_mm, wheel_roughness_ra_um, rail_roughness_ra_um "
                    "(wheel-rail). An answer also carries the options used, its provenance (the study's manifest "
                    "and posteriors by SHA-256, the filmcal version), the patch's size and any warning. Bad "
                    "requests get the protocol's error objects; each request's body, input and time are bounded "
                    "before the work. The study is only read. Ctrl-C stops.")
    add(p, "study_dir", required=True)
    local(p, "--host", default="127.0.0.1",
          help="address to listen on (default 127.0.0.1: this machine only; the protocol has no "
               "authentication, so another address lets anyone who reaches it use the server)")
    local(p, "--port", type=int, default=4242, help="port (default 4242, UM-Bridge's; 0 picks a free one)")
    add(p, "workers", default=2, help="threads running corrections at once (default 2)")
    local(p, "--request-timeout-s", type=float, default=120.0,
          help="longest wait for one answer in s (default 120): a wheel-rail correction at a new offset or load "
               "solves first; past it the request gets an error and the solve goes on")
    p.set_defaults(func=run)


def _check(args: argparse.Namespace) -> None:
    if not args.host.strip():  # "" would listen on every interface
        raise ValueError(f"--host must be an address or a host name, got {args.host!r}")
    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port must be 0-65535, got {args.port}")
    if not 1.0 <= args.request_timeout_s <= 3600.0:
        raise ValueError(f"--request-timeout-s must be 1-3600 s, got {args.request_timeout_s:g}")


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def run(args: argparse.Namespace) -> int:
    from filmcal.study.serve import MODELS, CorrectionServer

    _check(args)
    server = CorrectionServer(args.study_dir, host=args.host, port=args.port, workers=args.workers,
                              request_timeout_s=args.request_timeout_s)
    if not _loopback(args.host):
        print(f"filmcal serve: listening on {args.host}: the UM-Bridge protocol has no authentication, anyone who "
              "can reach this address can use the server", file=sys.stderr)
    from filmcal._versions import held_notes

    for text in held_notes():  # said before serving, which ends only with Ctrl-C
        print(f"filmcal serve: note: {text}", file=sys.stderr)
    print(f"serving {', '.join(MODELS)} of {args.study_dir} at {server.url} (Ctrl-C stops)", flush=True)
    server.serve_forever()
    return 0
