"""The command line's vocabulary: one option per concept, with its name, help, bounds and default written once.

Every command builds its options with `add` (a concept of `VOCABULARY`) or
`local` (an option only that command has). An option renamed in this
release stays for one release as a hidden alias (`renamed`) that prints one
line naming its new spelling and sets the new option's value. The tests derive
the concept -> option map from here: no command, JSON key or CSV column may
use an old name of a concept.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any, Callable

from filmcal._progress import MODES as PROGRESS_MODES
from filmcal.contact.names import IMPRINT_MODELS, KINEMATICS, MIXTURE
from filmcal.contact.options import CONTACT_MODES, ContactOptions

__all__ = ["Concept", "VOCABULARY", "add", "local", "renamed", "concept_of", "RENAMED", "missing_required"]


@dataclass(frozen=True)
class Concept:
    """One concept of the command line.

    Attributes
    ----------
    dest : str
        Its name in Python signatures, JSON keys and CSV columns.
    help : str
        What it is (each command may add what it does with it).
    type : callable, optional
        argparse type (`float`, `int`, ...).
    bounds : (low, high), optional
        Inclusive bounds checked when the option is parsed, and stated in its help.
    choices : tuple, optional
        The allowed values.
    metavar : str, optional
    action : argparse.Action subclass, optional
        Parses the option instead of ``type`` (one that needs its parser, e.g. to name its command).
    """

    dest: str
    help: str
    type: Callable[[str], Any] | None = None
    bounds: tuple[float, float] | None = None
    choices: tuple[str, ...] | None = None
    metavar: str | None = None
    action: type[argparse.Action] | None = None

    @property
    def flag(self) -> str:
        return "--" + self.dest.replace("_", "-")


#: Notes on old spellings met while parsing, said by the command line once the parse has succeeded (a refused
#: command line says one line only).
_NOTES: list[str] = []


def note_renamed(prog: str, old: str, new: str) -> None:
    """Keep the note that `old` is renamed `new` for `take_notes`."""
    _NOTES.append(f"{prog}: note: {old} is renamed {new}; the old name goes in the next release")


def take_notes() -> list[str]:
    """The notes kept since the last call (`note_renamed`), forgotten here."""
    notes = list(_NOTES)
    _NOTES.clear()
    return notes


class _ProgressMode(argparse.Action):
    """``--progress``: one of `PROGRESS_MODES` (the old ``live`` is ``bar``, said once, naming the command)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values == "live":
            note_renamed(parser.prog, "--progress live", "--progress bar")
            values = "bar"
        if values not in PROGRESS_MODES:
            parser.error(f"argument --progress: must be one of {', '.join(PROGRESS_MODES)}, got {values!r}")
        setattr(namespace, self.dest, values)


def _concepts(*items: Concept) -> dict[str, Concept]:
    return {c.dest: c for c in items}


_POSITIVE = (1e-12, 1e12)  # finite and > 0 (bounds stated as "> 0")
from filmcal._validation import FORCE_KN_BOUNDS, OFFSET_MM_BOUNDS, SPHERE_RADIUS_MM_BOUNDS  # noqa: E402 (one place)
from filmcal._validation import FILM_MODULUS_MPA_BOUNDS, FILM_THICKNESS_MM_BOUNDS  # noqa: E402
from filmcal._validation import MAX_RA_UM, MIN_RA_UM, arg_zero_or_in  # noqa: E402

VOCABULARY: dict[str, Concept] = _concepts(
    Concept("film", "film type: MS, HS, HHS, or a film of --films-file (or of the study)", metavar="NAME"),
    Concept("films", "film types, comma-separated", metavar="NAMES"),
    Concept("films_file", "user film types (TOML: name, activation pressure or range, thickness, nu)",
            metavar="TOML"),
    Concept("film_modulus_mpa", "film Young's modulus E in MPa", float, FILM_MODULUS_MPA_BOUNDS),
    Concept("film_poisson", "film Poisson's ratio nu", float, (-0.999, 0.499)),
    Concept("film_thickness_mm", "film thickness in mm", float, FILM_THICKNESS_MM_BOUNDS),
    Concept("imprint_model", "what the film records: edge (the whole contact), activation (where the pressure "
            "exceeds the film's activation pressure), capsule (the expected area of capsules broken)",
            choices=IMPRINT_MODELS),
    Concept("imprint_models", "what the film records, comma-separated: each is calibrated and compared "
            f"({', '.join(IMPRINT_MODELS)})", metavar="MODELS"),
    Concept("kinematics", "film kinematics: small (linear film) or large (neo-Hookean, large strain)",
            choices=KINEMATICS),
    Concept("sphere_radius_mm", "sphere radius R in mm", float, SPHERE_RADIUS_MM_BOUNDS),
    # a sphere test or a wheel load above 2 MN (a 200 t axle) is a unit error (N for kN), not a contact
    Concept("force_kn", "normal force F in kN", float, FORCE_KN_BOUNDS),
    Concept("forces_kn", "forces in kN: a list 50,100 or start:stop:step", metavar="LIST"),
    Concept("calibration_forces_kn", "choose the posterior calibrated on this force range in kN, e.g. 50-100",
            type=lambda t: force_range(t), metavar="RANGE"),
    Concept("offset_mm", "lateral offset eta in mm (the paper's convention; write --offset-mm=-3 for "
            "negative values)", float, OFFSET_MM_BOUNDS),
    Concept("offset_std_mm", "standard uncertainty of the lateral offset in mm (a ruler or gauge: about "
            "0.5-1 mm)", float, (0.0, 10.0)),
    Concept("offsets_mm", "lateral offsets eta in mm: a list -5,0 or start:stop:step", metavar="LIST"),
    Concept("wheel_roughness_ra_um", "roughness Ra of the wheel in um (a synthetic self-affine surface; 0: "
            f"smooth, else at least {MIN_RA_UM:g}) [allowed 0 to {MAX_RA_UM:g}]", arg_zero_or_in(MIN_RA_UM, MAX_RA_UM)),
    Concept("rail_roughness_ra_um", "roughness Ra of the rail in um (a synthetic self-affine surface, drawn "
            f"independently of the wheel's; 0: smooth, else at least {MIN_RA_UM:g}) [allowed 0 to {MAX_RA_UM:g}]",
            arg_zero_or_in(MIN_RA_UM, MAX_RA_UM)),
    Concept("wheel_roughness_map", "a measured surface of the wheel: an x3p map or profile, a stylus line "
            "profile across the lay (CSV with x_um or x_mm and z_um or z_nm columns), a CSV of heights or a "
            "greyscale PNG/TIFF, not JPEG (these two with --roughness-pixel-um)", metavar="FILE"),
    Concept("rail_roughness_map", "a measured surface of the rail (the formats of --wheel-roughness-map)",
            metavar="FILE"),
    Concept("roughness_pixel_um", "pixel size in um of a CSV or image roughness map", float, (0.001, 100.0)),
    Concept("roughness_height_scale", "CSV roughness map: factor from its numbers to um (default 1)", float,
            (1e-6, 1e6)),
    Concept("roughness_height_range_um", "image roughness map: height in um from black to full white", float,
            (0.001, 1000.0)),
    Concept("scan", "a scanned imprint (PNG, TIFF or JPEG)", metavar="FILE"),
    Concept("simulator_command", "a command template run once per design point; placeholders are the "
            "design's columns plus {work_dir} and {point_id}", metavar="TEMPLATE"),
    Concept("simulator_python", "a Python function MODULE:FUNCTION called with the design's columns",
            metavar="MODULE:FUNCTION"),
    Concept("simulator_umbridge", "the URL of a UM-Bridge server whose model runs one point (protocol 1.0)",
            metavar="URL"),
    Concept("umbridge_model", "the model's name on the UM-Bridge server", metavar="NAME"),
    Concept("dask", "address of a Dask distributed scheduler (tcp://host:port) to run on", metavar="ADDRESS"),
    Concept("progress", "progress on stderr: bar (live bars on a terminal), log (plain lines, a heartbeat at "
            "least every 10 s), quiet, or auto (bar on a terminal, log otherwise)",
            metavar="{" + ",".join(PROGRESS_MODES) + "}", action=_ProgressMode),
    Concept("study_dir", "study folder", metavar="DIR"),
    Concept("run_store", "folder of FE (or simulator) run stores shared by studies: a study given it reuses every "
            "run of the same settings that another study made there, and records the SHA-256 of the runs it used "
            "(default: the store the study was made with; for a new study $FILMCAL_RUN_STORE, else the user's cache, "
            "~/.cache/filmcal/runs; FILMCAL_RUN_STORE=study keeps each study's runs in its own runs/ folder)",
            metavar="DIR"),
    Concept("workers", "worker processes (1: everything in this process; at most 4 per core, and as many as fit "
            "in the memory available)", int, (1, 256)),
    Concept("seed", "seed of every random step", int, (0, 2**32 - 1)),
    Concept("json", "print one JSON object on stdout"),
)

#: Old option -> new option, of every command (filled as the parsers are built).
RENAMED: dict[str, str] = {}


def concept_of(action: argparse.Action) -> str | None:
    """The concept an option was built from (None: a command-local option or a hidden alias)."""
    return getattr(action, "filmcal_concept", None)


def missing_required(parser: argparse.ArgumentParser, args: argparse.Namespace) -> list[str]:
    """Required vocabulary options that neither their name nor an old alias gave."""
    return [a.option_strings[0] for a in parser._actions
            if getattr(a, "filmcal_required", False) and getattr(args, a.dest, None) is None]


def _bounded(concept: Concept):
    if concept.bounds is None or concept.type not in (int, float):
        return concept.type
    from filmcal._validation import arg_float_in, arg_int_in

    low, high = concept.bounds
    return (arg_int_in if concept.type is int else arg_float_in)(low, high)


def _bounds_text(concept: Concept) -> str:
    if concept.bounds is None:
        return ""
    low, high = concept.bounds
    return bounds_text(low, high, concept.type is int)


def bounds_text(low: float, high: float, integer: bool) -> str:
    """How a help states an option's inclusive bounds."""
    return f" [allowed {low} to {high}]" if integer else f" [allowed {low:g} to {high:g}]"


def add(parser, dest: str, help: str | None = None, *, extra: str = "", **kwargs: Any) -> argparse.Action:
    """Add the option of concept `dest` to a parser or group.

    Parameters
    ----------
    help : str, optional
        Replaces the concept's own help (use `extra` to add to it).
    extra : str
        Appended to the help (what this command does with the option, its default).
    kwargs
        Passed to ``add_argument`` (``default``, ``required``, ``action``, ``choices`` ...).
    """
    concept = VOCABULARY[dest]
    options: dict[str, Any] = {"dest": dest}
    if "action" not in kwargs and concept.action is not None:
        options["action"] = concept.action
        if concept.metavar is not None:
            options["metavar"] = concept.metavar
    elif "action" not in kwargs:
        if concept.type is not None:
            options["type"] = _bounded(concept)
        if concept.choices is not None:
            options["choices"] = concept.choices
        if concept.metavar is not None:
            options["metavar"] = concept.metavar
    options.update(kwargs)
    required = bool(options.pop("required", False))  # checked after parsing: an old alias may give it
    sep = "" if extra[:1] in (";", ",", ":") else " "
    text = (help or concept.help) + (f"{sep}{extra}" if extra else "") + _bounds_text(concept)
    action = parser.add_argument(concept.flag, help=text.replace("%", "%%"), **options)
    action.filmcal_concept = dest  # type: ignore[attr-defined]
    action.filmcal_required = required  # type: ignore[attr-defined]
    if concept.bounds is not None and concept.type in (int, float):
        action.type.filmcal_checked = True  # type: ignore[union-attr]
    return action


def local(parser, flag: str, **kwargs: Any) -> argparse.Action:
    """A command-local option (a concept no other command has); its flag must not be a concept's."""
    dest = kwargs.get("dest", flag.lstrip("-").replace("-", "_"))
    if dest in VOCABULARY:
        raise AssertionError(f"{flag}: {dest} is a concept of the vocabulary; build it with add()")
    action = parser.add_argument(flag, **kwargs)
    action.filmcal_local = True  # type: ignore[attr-defined]
    return action


class _Renamed(argparse.Action):
    """A hidden old spelling: prints one line naming the new one, then sets the new option's value(s)."""

    def __init__(self, option_strings, dest, new: str, convert: Callable[[Any], dict[str, Any]], **kwargs):
        self.new = new
        self.convert = convert
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        note_renamed(parser.prog, option_string, self.new)
        for dest, value in self.convert(values).items():
            setattr(namespace, dest, value)


def renamed(parser, old: str, new: str, dest: str | None = None, *, flag_value: Any = None,
            convert: Callable[[Any], dict[str, Any]] | None = None, type: Callable | None = None,
            choices: tuple | None = None) -> None:
    """Keep an old option as a hidden alias of `new` for one release.

    Parameters
    ----------
    old, new : str
        The old spelling and what to write instead (shown to the user).
    dest : str, optional
        The destination it sets (default: the new option's).
    flag_value : optional
        The old option was a flag: it sets `dest` to this value.
    convert : callable, optional
        ``convert(value) -> {dest: value, ...}`` for an old option that maps onto several.
    type : callable, optional
        Parses the old option's text.
    """
    dest = dest or new.split()[0].lstrip("-").replace("-", "_")
    if convert is None:
        if flag_value is not None:
            convert = lambda _value, d=dest, v=flag_value: {d: v}  # noqa: E731
        else:
            convert = lambda value, d=dest: {d: value}  # noqa: E731
    extra: dict[str, Any] = {"nargs": 0} if flag_value is not None else {}
    if type is not None:
        extra["type"] = type
    if choices is not None:
        extra["choices"] = choices
    action = parser.add_argument(old, dest=f"_renamed_{old.lstrip('-').replace('-', '_')}", action=_Renamed,
                                 new=new, convert=convert, default=argparse.SUPPRESS, **extra)
    action.filmcal_renamed = new  # type: ignore[attr-defined]
    RENAMED[old] = new


def add_contact_options(parser, prefix: str = "") -> None:
    """The FE interface options, with `ContactOptions`' defaults (``prefix``: "FE " where a command has others)."""
    d = ContactOptions()
    local(parser, "--sphere-contact", choices=CONTACT_MODES, default=d.sphere_contact,
          help=f"{prefix}sphere-film interface (default {d.sphere_contact})")
    local(parser, "--flat-contact", choices=CONTACT_MODES, default=d.flat_contact,
          help=f"{prefix}film-flat interface, never separating (default {d.flat_contact})")
    local(parser, "--friction-coefficient", type=float, default=d.friction_coefficient,
          help=f"Coulomb coefficient of 'friction' interfaces (default {d.friction_coefficient:g}, as the paper)")


def contact_options(args: argparse.Namespace) -> ContactOptions:
    """`ContactOptions` of a command's parsed interface and kinematics options."""
    return ContactOptions(sphere_contact=args.sphere_contact, flat_contact=args.flat_contact,
                          friction_coefficient=args.friction_coefficient, kinematics=args.kinematics)


def add_roughness_map_reading(parser) -> None:
    """How a CSV or image roughness map is read: --roughness-pixel-um, --roughness-height-scale (CSV),
    --roughness-height-range-um (image); see `roughness_map_reading`."""
    add(parser, "roughness_pixel_um")
    add(parser, "roughness_height_scale", default=1.0)
    add(parser, "roughness_height_range_um")


def roughness_map_reading(args: argparse.Namespace) -> dict[str, Any]:
    """The keywords of `filmcal.contact.surface_files.read_surface_file` from `add_roughness_map_reading`'s
    options."""
    return {"pixel_um": args.roughness_pixel_um, "height_scale": args.roughness_height_scale,
            "height_range_um": args.roughness_height_range_um}


def add_scan_resolution(parser, prefix: str = "") -> None:
    """--dpi and --mm-per-pixel of a scanned imprint, bounded (1 um to 1 mm pixels)."""
    from filmcal._validation import SCAN_PIXEL_MM_BOUNDS, arg_float_in

    low, high = SCAN_PIXEL_MM_BOUNDS
    local(parser, "--dpi", type=arg_float_in(25.0, 25400.0),
          help=f"{prefix}scan resolution in dots per inch (default: the file's resolution metadata) "
               "[allowed 25 to 25400]")
    local(parser, "--mm-per-pixel", type=arg_float_in(low, high),
          help=f"{prefix}pixel size in mm (instead of --dpi)" + bounds_text(low, high, False))


def rail_inclination(text: str) -> float:
    """A rail inclination from '1/40', '0.025' or '0' (a fraction or a number, 0 to 0.2)."""
    from fractions import Fraction

    try:
        value = float(Fraction(str(text).strip()))
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f"must be a number or a fraction like 1/40, got {text!r}") from None
    low, high = rail_inclination.bounds
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must lie in [{low:g}, {high:g}], got {text!r}")
    return value


rail_inclination.bounds = (0.0, 0.2)  # type: ignore[attr-defined]


def add_wheel_rail_options(parser, *, grid: bool = False) -> None:
    """The wheel-rail model's settings, with the model's own defaults (`filmcal.wheelrail.settings`)."""
    from filmcal.wheelrail import settings as d

    local(parser, "--rail", default=d.RAIL,
          help=f"rail profile: 60E2, 60E1, or a CSV file y_mm,z_mm in the rail's standard coordinates "
               f"(default {d.RAIL})")
    local(parser, "--wheel", default=d.WHEEL,
          help=f"wheel profile: S1002 or a CSV file y_mm,z_mm in the wheel's standard coordinates "
               f"(default {d.WHEEL})")
    local(parser, "--rail-inclination", type=rail_inclination, default=d.RAIL_INCLINATION, metavar="SLOPE",
          help="rail inclination as a fraction or a number, e.g. 1/40 (default), 1/20, 0.025, or 0 for an "
               "upright rail" + bounds_text(*rail_inclination.bounds, False))
    from filmcal._validation import arg_float_in

    local(parser, "--nominal-radius-mm", type=arg_float_in(150.0, 1500.0), default=d.NOMINAL_RADIUS_MM,
          help=f"the wheel's nominal rolling radius at its tape circle in mm (default {d.NOMINAL_RADIUS_MM:g}) "
               "[allowed 150 to 1500]")
    if grid:
        local(parser, "--grid-mm", type=float, default=d.GRID_MM,
              help=f"cell size of the contact grid in mm (default {d.GRID_MM:g}, the film's resolution)")
    renamed(parser, "--inclination", "--rail-inclination", type=rail_inclination)
    renamed(parser, "--wheel-radius-mm", "--nominal-radius-mm", type=float)


def split_model(text: str) -> dict[str, str]:
    """The old ``--model IMPRINT/KINEMATICS`` as ``imprint_model`` and ``kinematics``."""
    imprint, _, kinematics = str(text).partition("/")
    out = {"imprint_model": imprint}
    if kinematics:
        out["kinematics"] = kinematics
    return out



def force_range(text: str) -> str:
    """A force range in kN, ``LOW-HIGH`` or ``VALUE`` (checked here, parsed by the calibration)."""
    from filmcal._validation import FORCE_RANGE

    match = FORCE_RANGE.match(str(text))
    if match is None or (match.group(2) is not None and float(match.group(1)) > float(match.group(2))):
        raise argparse.ArgumentTypeError(f"must be a force range in kN such as 50-100 (low <= high) or 75, "
                                         f"got {text!r}")
    return text


#: The imprint-model choices of commands that read a study: a model, or the study's weighted mixture.
STUDY_IMPRINT_MODELS = (*IMPRINT_MODELS, MIXTURE)


def add_simulator_options(parser) -> None:
    """A lab's own simulator in place of the in-house FE: --simulator-python, --simulator-command (with
    --template-file) or --simulator-umbridge (with --umbridge-model), and --timeout-s; read by
    `filmcal.commands._common.simulator_from_args`."""
    sim = parser.add_argument_group("a lab's own simulator in place of the in-house FE (docs/calibration.md)")
    which = sim.add_mutually_exclusive_group()
    add(which, "simulator_python", extra="; called with modulus_mpa, poisson, sphere_radius_mm, force_kn, "
        "film_thickness_mm, it returns contact_radius_mm and optionally the pressure profile radius_mm, "
        "pressure_mpa (lists) from which every imprint model is read")
    add(which, "simulator_command", help="a command template run once per design point, in a fresh folder; "
        "placeholders {modulus_mpa}, {poisson}, {sphere_radius_mm}, {force_kn}, {film_thickness_mm}, {work_dir}, "
        "{point_id}; it prints (or writes to outputs.json) a JSON object with contact_radius_mm and optionally "
        "radius_mm, pressure_mpa")
    add(which, "simulator_umbridge", extra="; input [[modulus_mpa, poisson, sphere_radius_mm, force_kn, "
        "film_thickness_mm]], output [[contact_radius_mm]] and optionally [radius_mm], [pressure_mpa]")
    add(sim, "umbridge_model")
    local(sim, "--template-file", action="append", metavar="FILE",
          help="input file template rendered into each run's folder (NAME.tmpl is written as NAME); repeatable")
    local(sim, "--timeout-s", type=float, metavar="T",
          help="deadline of one --simulator-command or --simulator-umbridge run in seconds")
