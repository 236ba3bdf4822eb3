"""Helpers shared by the subcommands: JSON output and common options."""
from __future__ import annotations

import json
import sys

from filmcal._json import json_safe


def print_json(payload: dict) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(json.dumps(json_safe(payload), indent=2) + "\n")


def simulator_from_args(args):
    """The lab's simulator of `add_simulator_options`' options (None: the in-house FE), checked before any
    work."""
    from filmcal._errors import InputError

    command, python, umbridge = args.simulator_command, args.simulator_python, args.simulator_umbridge
    if command is None and args.template_file:
        raise InputError("--template-file needs --simulator-command")
    if command is None and umbridge is None and args.timeout_s is not None:
        raise InputError("--timeout-s needs --simulator-command or --simulator-umbridge")
    if umbridge is None and args.umbridge_model is not None:
        raise InputError("--umbridge-model needs --simulator-umbridge")
    if command is None and python is None and umbridge is None:
        return None
    from filmcal.campaign import CommandModel
    from filmcal.campaign.simulator import Simulator

    if python is not None:
        return Simulator(python=python)
    if umbridge is not None:
        return Simulator(umbridge=umbridge, umbridge_model=args.umbridge_model, timeout_s=args.timeout_s)
    files = CommandModel.from_files(command, ".", args.template_file or ()).template_files
    return Simulator(command=command, template_files=files, timeout_s=args.timeout_s)
