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


#: Peak memory of the commands that build roughness laws, besides the laws (bytes; measured: wheelrail 101 MiB
#: without a map, curves' parent 294 MiB and workers 273 MiB with a synthetic rough wheel, correct 106 MiB without
#: roughness and 216 MiB with a 256 x 256 map and 3 draws, of which its 4 laws 100 MiB).
ROUGH_COMMAND_BASE_BYTES = {"wheelrail": 110 * 2**20, "curves": 300 * 2**20, "correct": 120 * 2**20}


#: Draws of the roughness law's conditioned inputs a rough band takes unless told otherwise.
DEFAULT_ROUGHNESS_DRAWS = 8


def roughness_draws(args, batch: bool = False) -> int:
    """``--roughness-draws`` as given, or `DEFAULT_ROUGHNESS_DRAWS`; refused when given for smooth bodies (and
    a measured law, which has no inputs to draw), where it would be ignored. A ``batch``'s rows may name rough
    bodies of their own."""
    if args.roughness_draws is None:
        return DEFAULT_ROUGHNESS_DRAWS
    rough = batch or any(getattr(args, name, None) for name in (
        "wheel_roughness_ra_um", "rail_roughness_ra_um", "wheel_roughness_map", "rail_roughness_map"))
    if not rough:
        from filmcal._errors import InputError

        raise InputError("--roughness-draws applies to rough bodies: give --wheel-roughness-ra-um, "
                         "--rail-roughness-ra-um or a roughness map with it")
    return args.roughness_draws


def _check_map_reading(args, maps: list) -> None:
    """Refuse a map-reading option (`add_roughness_map_reading`) that none of the given maps reads: given without
    a map, or a CSV's height scale for an image, a pixel size for an x3p file or a line profile."""
    given = [(option, dest) for option, dest, unset in (
        ("--roughness-pixel-um", "pixel_um", None), ("--roughness-height-scale", "height_scale", 1.0),
        ("--roughness-height-range-um", "height_range_um", None))
        if getattr(args, "roughness_" + dest, unset) != unset]
    if not given:
        return
    from filmcal._errors import InputError

    if not maps:
        raise InputError(f"{given[0][0]} says how a roughness map is read: give --wheel-roughness-map or "
                         "--rail-roughness-map with it")
    from filmcal.contact.surface_files import READING_OPTIONS, surface_file_kind

    kinds = {surface_file_kind(path) for path in maps}
    for option, dest in given:
        if not any(dest in READING_OPTIONS[kind] for kind in kinds):
            raise InputError(f"{option} does not apply to the roughness map given ({', '.join(sorted(kinds))}): "
                             "an x3p file and a line profile carry their own scales, a CSV height map takes "
                             "--roughness-pixel-um and --roughness-height-scale, an image --roughness-pixel-um and "
                             "--roughness-height-range-um; leave it out")


def check_roughness_maps(args, command: str, film_laws_per_map: int, steel_laws_per_map: int = 1,
                         copies: int = 1, advice: str = "crop the map") -> None:
    """Check the roughness maps a command was given before any work: each at most
    `filmcal.contact.surface_files.MAX_MAP_PIXELS` pixels (read from its header), and the boundary-element laws
    the command builds on them (`filmcal.contact.roughness.rough_law_cost`: `film_laws_per_map` against the
    film and `steel_laws_per_map` steel on steel per map, held in `copies` processes) within the memory
    available now.

    Raises
    ------
    filmcal._errors.InputError, ValueError
        Naming the option and the file, the limit and why.
    """
    given = [(option, getattr(args, dest, None)) for option, dest in (
        ("--wheel-roughness-map", "wheel_roughness_map"), ("--rail-roughness-map", "rail_roughness_map"))]
    _check_map_reading(args, [path for _, path in given if path is not None])
    if all(path is None for _, path in given):
        return  # nothing to read: nothing imported (a correction without maps starts fast)
    from filmcal._memory import check_memory
    from filmcal.contact.roughness import rough_law_cost
    from filmcal.contact.surface_files import check_map_pixels, surface_file_shape

    maps = []
    for option, path in given:
        if path is None:
            continue
        shape = surface_file_shape(path)
        check_map_pixels(path, option, shape)
        if shape is not None:
            maps.append((option, path, shape))
    if not maps:
        return
    pixels = max(rows * cols for _, _, (rows, cols) in maps)
    n = len(maps)
    cost = rough_law_cost(pixels, film_laws_per_map * n, steel_laws_per_map * n, copies,
                          ROUGH_COMMAND_BASE_BYTES.get(command, 0.0))
    names = " and ".join(f"{option} ({rows} x {cols} pixels)" for option, _, (rows, cols) in maps)
    check_memory(cost, names, advice)
