"""The `filmcal` command.

A thin dispatcher: each subcommand lives in `filmcal.commands.<name>` with an
``add_parser(subparsers)`` that registers its options and sets
``func(args) -> int``. No science lives here.

This module is the command line's one error boundary:

- Before any work, every option is checked: numbers are finite, size
  options lie in their bounds (`SIZE_BOUNDS`) and lists of loads or offsets
  are not too long (`GRID_BOUNDS`), both stated in ``--help``; ``--workers``
  is at most 4 per core and its processes fit in the memory available now
  (`check_workers_option`; the commands check their own sizes against it
  too: the FE mesh, roughness maps, `filmcal._memory`); output
  files are not folders and their folder exists and is writable, study
  folders are not files, input files are regular files of bounded size
  (`preflight`). A bad option ends the command before
  anything is computed or written.
- A failure that is the user's input or the user's files (`ValueError` and its
  subclasses `filmcal._errors.InputError` and `DamagedFileError`, operating
  system errors on a path, a file that cannot be decoded as JSON, SQLite, npz,
  HDF5 or an image, a size that exhausts memory) ends with exit status 2 and
  exactly one line on stderr that names the option or the file and what to
  do.
- Ctrl-C ends with one line and status 130.
- Anything else is an internal error (a bug): its traceback stays visible,
  followed by one line, and the status is 70 (``EX_SOFTWARE`` of BSD's
  sysexits).
"""
from __future__ import annotations

import _thread
import argparse
import contextlib
import errno
import importlib
import os
import pkgutil
import re
import signal
import sys
import threading
import traceback
import warnings
from pathlib import Path

import filmcal.commands
from filmcal._errors import DamagedFileError
from filmcal._validation import SPHERE_RADIUS_MM_BOUNDS, arg_finite, arg_float_in, arg_grid, arg_int, arg_int_in
from filmcal._versions import VersionNote, held_notes, hold_note
from filmcal.commands._options import bounds_text, missing_required, take_notes

__all__ = ["main", "build_parser", "preflight", "SIZE_BOUNDS",
           "EXIT_OK", "EXIT_USER", "EXIT_INTERNAL", "EXIT_INTERRUPTED"]

EXIT_OK = 0
EXIT_USER = 2          # bad option, bad or damaged file: one line on stderr
EXIT_INTERNAL = 70     # a bug: traceback on stderr
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT)

# The order in which `--help` lists the subcommands; any other module in
# `filmcal.commands` (not starting with "_") follows in alphabetical order.
ORDER = ["pipeline", "fem", "doe", "campaign", "calibrate", "profile", "wheelrail", "correct", "scan", "report"]

# Bounds of the size options of every command, by option destination
# (inclusive). They keep a mistyped size from exhausting memory or running
# for days; they are checked when the options are parsed, before any work,
# and stated in each option's help. A command may set its own (tighter) check.
SIZE_BOUNDS: dict[str, tuple[float, float]] = {
    "workers": (1, 256),
    "seed": (0, 2**32 - 1),
    "roughness_seed": (0, 2**32 - 1),
    "roughness_draws": (1, 16),
    "elastic_limit_mpa": (100.0, 1e4),
    "samples": (1, 2000),
    "iterations": (1, 1000),
    "element_size_mm": (0.02, 1.0),  # MeshSettings' own bound above
    "sphere_radius_mm": SPHERE_RADIUS_MM_BOUNDS,
    "film_layers": (1, 8),
    "grid_mm": (0.01, 1.0),  # the wheel-rail model's own (filmcal.wheelrail.settings.GRID_MM_RANGE)
    "friction_coefficient": (0.0, 10.0),  # ContactOptions' bound
    "step_mm": (0.001, 50.0),  # profile sampling
    "threshold": (0.0, 1.0),  # a scan's stain intensity
    "train_runs": (20, 5000),
    "test_runs": (5, 5000),
    "max_steps": (1, 1_000_000),
    "timeout_s": (0.001, 7 * 24 * 3600.0),
}

# Options that take a list or a start:stop:step range, with the most values
# each may give (curves: about 2 s per load, offset and wheel).
GRID_BOUNDS: dict[str, int] = {"forces_kn": 50, "offsets_mm": 200}

# Path options by destination: files that a command writes, folders it
# writes into, and files it only reads. Checked before any work.
OUTPUT_FILE_DESTS = ("out", "csv", "plot", "overview", "pressure_csv", "outline_out")
OUTPUT_DIR_DESTS = ("study_dir", "out_dir", "plots", "work_dir", "run_store")
INPUT_FILE_DESTS = ("design", "augment", "scan", "sheet", "batch", "roughness_law", "wheel_roughness_map", "rail_roughness_map",
                    "data", "films_file",
                    "template_file")
# Options that take a standard profile's name or a profile CSV file: checked as input files when they name a file.
PROFILE_DESTS = ("name", "wheel", "rail")
# The largest input file of each option in MiB, where it differs from `filmcal._io.INPUT_FILE_MAX_MIB`
# (256 MiB: datasets, film files, designs, profiles, laws): measured surfaces and scanned images are larger,
# a campaign store is read by SQLite a page at a time.
INPUT_FILE_CAPS_MIB: dict[str, float] = {"wheel_roughness_map": 1024, "rail_roughness_map": 1024, "scan": 1024,
                                         "sheet": 1024, "store": 4096}
PLOT_SUFFIXES = (".png", ".pdf", ".svg")


def command_modules() -> list[str]:
    """Names of the subcommand modules in `filmcal.commands`."""
    names = [m.name for m in pkgutil.iter_modules(filmcal.commands.__path__) if not m.name.startswith("_")]
    return sorted(names, key=lambda n: (ORDER.index(n) if n in ORDER else len(ORDER), n))


class OneLineParser(argparse.ArgumentParser):
    """An `ArgumentParser` whose usage errors are one line on stderr, exit 2."""

    def error(self, message: str) -> None:  # noqa: D401 - argparse API
        sys.stderr.write(f"{self.prog}: error: {_one_line(message)}\n")
        raise SystemExit(EXIT_USER)


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _after(first, then):
    """An argparse type: `first` converts and checks, `then` checks the bounds of the same text."""
    def parse(text: str):
        value = first(text)
        then(text)
        return value
    parse.__name__ = then.__name__
    parse.filmcal_checked = True  # type: ignore[attr-defined]
    parse.bounds = then.bounds  # type: ignore[attr-defined]
    return parse


def _harden(parser: argparse.ArgumentParser) -> None:
    """Bounds and finite checks on a parser's options, recursively; help without '%%'.

    argparse %-formats help strings but not descriptions, so a description
    written with '90 %%' would show both signs: it is shown with one.
    """
    if parser.description and "%%" in parser.description:
        parser.description = parser.description.replace("%%", "%")
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _harden(sub)
            continue
        convert = action.type
        if action.dest in GRID_BOUNDS and convert in (None, str) and action.nargs is None:
            action.type = arg_grid(GRID_BOUNDS[action.dest])
            if action.help and action.help is not argparse.SUPPRESS:
                action.help = f"{action.help} [at most {GRID_BOUNDS[action.dest]} values]"
            continue
        if convert is None or getattr(convert, "filmcal_checked", False):
            continue
        if action.dest in SIZE_BOUNDS and convert is not str:
            low, high = SIZE_BOUNDS[action.dest]
            integer = convert is int or isinstance(low, int) and isinstance(high, int)
            bounded = (arg_int_in if integer else arg_float_in)(low, high)
            if convert not in (int, float):  # the command's own type first, then the bounds
                bounded = _after(convert, bounded)
            action.type = bounded
            if action.help and action.help is not argparse.SUPPRESS:
                action.help = action.help + bounds_text(low, high, integer)
        elif convert is float:
            action.type = arg_finite()
        elif convert is int:
            action.type = arg_int()


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every subcommand registered."""
    parser = OneLineParser(
        prog="filmcal",
        description="Calibrate a finite-element model of Prescale film against "
                    "sphere-on-flat experiments and correct wheel-rail contact areas "
                    "measured with film, with their uncertainty.",
        epilog="Exit status: 0 done, 1 a result that did not converge, 2 a bad option or "
               "a bad or damaged file (one line on stderr), 70 an internal error (traceback), "
               "130 interrupted.",
    )
    from filmcal._versions import __version__
    parser.add_argument("--version", action="version", version=f"filmcal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for name in command_modules():
        importlib.import_module(f"filmcal.commands.{name}").add_parser(sub)
    _harden(parser)
    return parser


# --- checks of path options before any work ------------------------------------

def _command_parser(parser: argparse.ArgumentParser, command: list[str]) -> argparse.ArgumentParser:
    """The (sub)parser of the command named by `command`."""
    current = parser
    for name in command:
        current = _subparsers(current).get(name, current)
    return current


def _command_actions(parser: argparse.ArgumentParser, command: list[str]) -> dict[str, argparse.Action]:
    """Destination -> option or positional argument of the (sub)command named by `command` (no subcommands)."""
    return {action.dest: action for action in _command_parser(parser, command)._actions
            if not isinstance(action, argparse._SubParsersAction)}


def _option_strings(actions: dict[str, argparse.Action]) -> dict[str, str]:
    """Destination -> long option string; a positional argument's name as its usage shows it."""
    options: dict[str, str] = {}
    for dest, action in actions.items():
        longs = [s for s in action.option_strings if s.startswith("--")]
        options[dest] = (longs or action.option_strings or [action.metavar or dest])[0]
    return options


def unrecognized_message(parser: argparse.ArgumentParser, prog: str, unknown: list[str]) -> str:
    """What a command says of arguments it does not take: them, the nearest option of its own to each
    unknown option, and where its options are listed."""
    import difflib

    own = [s for a in parser._actions if a.help != argparse.SUPPRESS for s in a.option_strings
           if s.startswith("--")]
    near = {}
    for arg in unknown:
        name = arg.split("=", 1)[0]
        if name.startswith("--"):
            match = difflib.get_close_matches(name, own, n=1, cutoff=0.75)
            if match:
                near[name] = match[0]
    hint = "; ".join(f"{old}: did you mean {new}?" for old, new in near.items())
    return (f"unrecognized arguments: {' '.join(unknown)} ({hint + '; ' if hint else ''}"
            f"`{prog} --help` lists its options)")


def preflight(args: argparse.Namespace, actions: dict[str, argparse.Action]) -> None:
    """Check the path options of a parsed command line before any work.

    Output files must not be folders and their folder must exist and be
    writable; plots must end in .png, .pdf or .svg; output folders must not be
    files; read-only inputs (a profile option's only when it names a file)
    must be existing regular files no larger than their cap
    (`INPUT_FILE_CAPS_MIB`, else `filmcal._io.INPUT_FILE_MAX_MIB`); no two
    of them may name one file.

    Raises
    ------
    filmcal._errors.InputError
        Naming the option.
    """
    from filmcal._errors import InputError
    from filmcal._io import (INPUT_FILE_MAX_MIB, check_distinct_files, check_input_file, check_output_dir,
                             check_output_file)

    options = _option_strings(actions)

    def opt(dest: str) -> str:
        return options.get(dest, "--" + dest.replace("_", "-"))

    def path_value(dest: str) -> str | None:
        action = actions.get(dest)
        value = getattr(args, dest, None)
        if action is None or action.choices is not None or not isinstance(value, str):
            return None
        return value

    def path_values(dest: str) -> list[str]:
        """The paths of an option given once, or of each time a repeatable one was given."""
        action = actions.get(dest)
        value = getattr(args, dest, None)
        if action is not None and action.choices is None and isinstance(value, list):
            return [v for v in value if isinstance(v, str)]
        single = path_value(dest)
        return [] if single is None else [single]

    for dest in OUTPUT_FILE_DESTS:
        value = path_value(dest)
        if value is not None:
            check_output_file(value, opt(dest))
            if dest in ("plot", "overview") and Path(value).suffix.lower() not in PLOT_SUFFIXES:
                raise InputError(f"{opt(dest)} must end in {', '.join(PLOT_SUFFIXES)}, got {value!r}")
    for dest in OUTPUT_DIR_DESTS:
        value = path_value(dest)
        if value is not None:
            # a study folder's results may be only read (correct, curves): its writer checks it further
            check_output_dir(value, opt(dest), writable=dest != "study_dir")
    for dest in INPUT_FILE_DESTS:
        for value in path_values(dest):
            check_input_file(value, opt(dest), INPUT_FILE_CAPS_MIB.get(dest, INPUT_FILE_MAX_MIB))
    # one file for two options: an output written over another, or over an input (each command adds the files
    # it derives, such as a provenance beside its table)
    check_distinct_files(*[(value, opt(dest)) for dest in (*INPUT_FILE_DESTS, *OUTPUT_FILE_DESTS)
                           for value in path_values(dest)])
    for dest in PROFILE_DESTS:
        value = path_value(dest)
        if value is not None and _names_a_profile_file(value):
            check_input_file(value, opt(dest))
    store = path_value("store")
    if store is not None:
        if getattr(args, "action", None) == "run":
            check_output_file(store, opt("store"))
        else:
            check_input_file(store, opt("store"), INPUT_FILE_CAPS_MIB["store"])


#: Commands whose --workers are threads of the command's own process, not worker processes.
THREAD_WORKERS = ("serve",)
#: Commands that check their worker processes' memory themselves, from what the workers will run (a campaign's
#: FE design: `filmcal.commands.campaign.check_design_memory`); here only the cap of 4 per core.
OWN_WORKER_CHECK = ("campaign",)


def check_workers_option(args: argparse.Namespace, actions: dict[str, argparse.Action], command: str) -> None:
    """Check ``--workers`` before any work: at most 4 per core (`filmcal._memory.max_workers`), and, for
    worker processes, their measured memory (`filmcal._memory.worker_memory`) within the memory available
    now. A command whose workers hold more (a campaign's finer FE meshes, the curves' roughness maps) checks
    that itself.

    Raises
    ------
    filmcal._errors.InputError
        Naming --workers, the limit and why.
    """
    if "workers" not in actions or getattr(args, "dask", None) is not None:
        return
    from filmcal._memory import check_workers

    option = _option_strings({"workers": actions["workers"]})["workers"]
    check_workers(getattr(args, "workers", None), option, command, processes=command not in THREAD_WORKERS,
                  memory=command not in OWN_WORKER_CHECK)


def _names_a_profile_file(value: str) -> bool:
    """True if a profile option's value is a file (a CSV, or any existing path) rather than a standard name."""
    from filmcal.wheelrail.profiles import PROFILE_NAMES

    if value.strip().upper() in {name.upper() for name in PROFILE_NAMES}:
        return False
    return value.lower().endswith(".csv") or os.path.lexists(value)


# --- the error boundary ---------------------------------------------------------

def _one_line(text: str) -> str:
    """Collapse a message to one line."""
    parts = [" ".join(line.split()) for line in str(text).splitlines()]
    return "; ".join(p for p in parts if p)


# Library parameters whose name differs from the option that feeds them.
PARAMETER_ALIASES = {"force_n": "force_kn"}


def _name_option(message: str, options: dict[str, str]) -> str:
    """Prefix the option (``--force-kn: ``) to a message that names its parameter (``force_kn``).

    A message naming a library parameter (``modulus_mpa``) is matched to the one
    option whose destination ends with it (``film_modulus_mpa``).
    """
    if "--" in message:
        return message
    usable = {d: o for d, o in options.items() if o.startswith("--") and d not in ("help", "json")}
    # a message about a file's content names its columns, not options: only its lead names an option
    about_file = re.match(r"(batch|dataset|roughness map|films file) ", message) is not None
    for dest in sorted(usable, key=len, reverse=True):  # said in words: "films file F: ..." is --films-file's
        if "_" in dest and message.startswith(dest.replace("_", " ") + " "):
            return f"{usable[dest]}: {message}"
    for dest in sorted(usable, key=len, reverse=True):
        if message.startswith(dest + " ") or message.startswith(dest + ":") or (
                "_" in dest and not about_file and re.search(rf"(?<![\w-]){re.escape(dest)}(?![\w-])", message)):
            return f"{usable[dest]}: {message}"
    lead = re.match(r"([a-z][a-z0-9]*(?:_[a-z0-9]+)*)\b", message)
    if lead:
        word = PARAMETER_ALIASES.get(lead.group(1), lead.group(1))
        matches = [d for d in usable if d == word or d.endswith("_" + word)]
        if len(matches) == 1 and (word in usable or "_" in word or word in ("poisson", "modulus")):
            return f"{usable[matches[0]]}: {message}"
    return message


_DECODE_ERRORS = ("JSONDecodeError", "DatabaseError", "OperationalError", "IntegrityError", "BadZipFile",
                  "UnidentifiedImageError", "DecompressionBombError", "DecompressionBombWarning", "UnicodeDecodeError",
                  "EOFError")
# Libraries that decode files: an error raised inside one of them while a file
# of the user or of a study is open is that file's damage, not a bug.
_DECODER_MODULES = ("h5py", "h5netcdf", "netCDF4", "xarray.backends", "zipfile", "PIL", "numpy.lib.format",
                    "numpy.lib.npyio", "numpy.lib._format_impl", "numpy.lib._npyio_impl", "sqlite3", "json",
                    "csv", "tomllib", "gzip", "emcee.backends")
_DECODER_ERRORS = (RuntimeError, KeyError, IndexError, EOFError, OSError, ValueError)


def _raised_in_decoder(exc: BaseException) -> bool:
    """True if the innermost Python frame of `exc` belongs to a file-decoding library."""
    frames = [f for f, _ in traceback.walk_tb(exc.__traceback__)]
    if not frames:
        return False
    module = str(frames[-1].f_globals.get("__name__", ""))
    return any(module == m or module.startswith(m + ".") for m in _DECODER_MODULES)


_PATH_LOCALS = re.compile(r"(^|_)(path|file|filename|fname|store)$")


def _file_of(exc: BaseException) -> str | None:
    """The file a decode error was reading: its attribute, its message or the reading frame's locals."""
    for attr in ("path", "filename"):
        value = getattr(exc, attr, None)
        if isinstance(value, (str, os.PathLike)) and str(value):
            return str(value)
    match = re.search(r"name = '([^']+)'", str(exc))  # h5py's messages
    if match:
        return match.group(1)
    seen: list[BaseException] = []
    current: BaseException | None = exc
    while current is not None and current not in seen:
        seen.append(current)
        current = current.__cause__ or current.__context__
    for err in seen:
        frames = [f for f, _ in traceback.walk_tb(err.__traceback__)]
        for frame in reversed(frames):  # innermost first
            candidates = [v for k, v in frame.f_locals.items() if _PATH_LOCALS.search(k)]
            owner = frame.f_locals.get("self")
            if owner is not None:
                candidates += [getattr(owner, a, None) for a in ("path", "filename", "_path")]
            for value in candidates:
                if isinstance(value, (str, os.PathLike)) and str(value) and os.path.isfile(value):
                    return str(value)
    return None


def _given_by(path: str, args: argparse.Namespace, options: dict[str, str]) -> str | None:
    """The option whose value is `path`, if the user named this file directly."""
    try:
        target = os.path.realpath(path)
    except (OSError, ValueError):
        return None
    for dest, value in vars(args).items():
        if isinstance(value, str) and value:
            try:
                if os.path.realpath(value) == target:
                    return options.get(dest, "--" + dest.replace("_", "-"))
            except (OSError, ValueError):
                continue
    return None


def _damaged_message(exc: BaseException, args: argparse.Namespace, options: dict[str, str]) -> str:
    path = _file_of(exc)
    reason = _one_line(f"{type(exc).__name__}: {exc}") if str(exc) else type(exc).__name__
    if path is None:
        return f"a file could not be read ({reason}); check the files given and the study folder"
    option = _given_by(path, args, options)
    if option is not None:
        return f"{option} {path!r} is damaged or not the expected kind of file ({reason}); check it or give another"
    return str(DamagedFileError(path, reason, recomputable=True))


def _os_message(exc: OSError, args: argparse.Namespace, options: dict[str, str]) -> str:
    name = exc.filename
    what = exc.strerror or _one_line(str(exc)) or type(exc).__name__
    if name is None:
        return _one_line(str(exc)) or type(exc).__name__
    option = _given_by(str(name), args, options)
    label = f"{option} {str(name)!r}" if option else repr(str(name))
    advice = {
        FileNotFoundError: "check the name",
        IsADirectoryError: "give a file, not a folder",
        NotADirectoryError: "a part of the path is a file, not a folder",
        PermissionError: "choose a place you may write to, or change its permissions",
        FileExistsError: "remove it or choose another name",
    }.get(type(exc), "check the path")
    return f"{label}: {what}; {advice}"


def _full_disk(exc: BaseException, args: argparse.Namespace | None = None,
               options: dict[str, str] | None = None) -> str | None:
    """The one line for a write that found no space (ENOSPC, or a disk quota) anywhere in the error's chain.

    It names the file being written (``filmcal._io``'s atomic writers put it
    on the error), with the option that gave it, and advises no deletion: an
    atomic write leaves the old file whole and no temporary file behind.
    """
    seen: list[BaseException] = []
    current: BaseException | None = exc
    while current is not None and current not in seen:
        seen.append(current)
        if isinstance(current, OSError) and current.errno in (errno.ENOSPC, errno.EDQUOT):
            name = os.fsdecode(current.filename) if isinstance(current.filename, (str, bytes, os.PathLike)) else ""
            option = _given_by(name, args, options or {}) if name and args is not None else None
            where = f" writing {option + ' ' if option else ''}{name!r}" if name else ""
            return (f"no space left on the device{where}: free some space and run again (no file was damaged, "
                    "and a study resumes where it stopped)")
        current = current.__cause__ or current.__context__
    return None


def user_error_message(exc: BaseException, args: argparse.Namespace, options: dict[str, str]) -> str | None:
    """One line for a failure that is the user's input or files; None for an internal error."""
    name = type(exc).__name__
    full = _full_disk(exc, args, options)
    if full is not None:  # before any "damaged" reading: a full disk damages nothing, and nothing is to delete
        return full
    if isinstance(exc, DamagedFileError):
        return _one_line(str(exc))
    if isinstance(exc, OSError) and "unable to lock file" in str(exc).lower():  # h5py's lock
        held = _file_of(exc)
        return (f"{held or 'a file'} is in use by another process ({_one_line(str(exc))}); wait for it "
                "to finish, or use another study folder")
    if name in _DECODE_ERRORS or any(c.__name__ in _DECODE_ERRORS for c in type(exc).__mro__):
        if name == "OperationalError" and "locked" in str(exc):
            return f"{_one_line(str(exc))}: another filmcal is writing the same file; wait for it to finish"
        if name == "OperationalError" and "unable to open" in str(exc):
            return f"cannot open the store ({_one_line(str(exc))}); check --store"
        return _damaged_message(exc, args, options)
    if type(exc).__module__ == "_csv" or (
            isinstance(exc, _DECODER_ERRORS) and not isinstance(exc, ConnectionError)
            and _raised_in_decoder(exc) and _file_of(exc) is not None):
        return _damaged_message(exc, args, options)
    if isinstance(exc, ValueError):
        text = exc.args[0] if len(exc.args) == 1 and isinstance(exc.args[0], str) else str(exc)
        if "pickled data" in text or "allow_pickle" in text:
            return _damaged_message(exc, args, options)
        return _name_option(_one_line(text), options) or name
    if isinstance(exc, OSError):
        if exc.filename is None and _file_of(exc) is not None and not isinstance(exc, ConnectionError):
            return _damaged_message(exc, args, options)
        return _os_message(exc, args, options)
    if isinstance(exc, MemoryError):
        return "not enough memory for these sizes; choose smaller sizes (see --help for the bounds)"
    return None


def _notes_as_one_line(prog: str) -> None:
    """Keep `VersionNote` warnings, each once, for `_say_notes` (a refused command says one line only), and
    show other warnings as one line ``prog: warning: Category: message`` (its first line; no file, line
    number or source line)."""

    def showwarning(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, VersionNote):
            hold_note(str(message))
        else:
            first = str(message).strip().splitlines()[0] if str(message).strip() else ""
            sys.stderr.write(f"{prog}: warning: {category.__name__}: {first}\n")

    warnings.showwarning = showwarning
    warnings.simplefilter("always", VersionNote)


def _say_notes(prog: str) -> None:
    """The `VersionNote`s kept while the command ran, one line each: ``prog: note: ...``."""
    for text in held_notes():
        sys.stderr.write(f"{prog}: note: {text}\n")


def _restore_ctrl_c() -> None:
    """Make Ctrl-C interrupt this process even if it was started with SIGINT ignored.

    A parent that ignores SIGINT (a shell's background job, ``nohup``) passes
    that on, and Python then installs no handler, so Ctrl-C would be ignored.
    Only this (main) process is restored: the workers of `filmcal._parallel`
    ignore SIGINT on purpose and leave it to this process. Only the main
    thread may set a handler.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.default_int_handler)


@contextlib.contextmanager
def _swallowed_ctrl_c_redelivered():
    """Deliver again a Ctrl-C that Python swallowed, for as long as the block runs.

    A SIGINT that arrives while Python runs a weakref callback or a ``__del__``
    (the import system's module-lock callbacks, for one) raises its
    `KeyboardInterrupt` there, where Python only prints "Exception ignored"
    and goes on: the command would run to its end. The unraisable hook
    catches exactly that case and interrupts the main thread once more, so
    that the interrupt reaches the command's boundary; any other unraisable
    exception goes to the hook that was there. The new interrupt comes from a
    timer thread a moment later: raised in the hook itself, it would be
    swallowed again.
    """
    previous = sys.unraisablehook

    def hook(unraisable):
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            timer = threading.Timer(0.02, _thread.interrupt_main)
            timer.daemon = True
            timer.start()
        else:
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous


def main(argv: list[str] | None = None) -> int:
    """Run the `filmcal` command line; return the exit status.

    Returns
    -------
    int
        0 done; 1 a result that did not converge (where a command says so);
        2 a bad option or file (one line on stderr); 70 an internal error
        (traceback on stderr); 130 interrupted.
    """
    _restore_ctrl_c()
    with _swallowed_ctrl_c_redelivered():
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        try:
            parser = build_parser()
        except Exception:  # noqa: BLE001 - a command that cannot register itself is a bug
            traceback.print_exc(file=sys.stderr)
            sys.stderr.write("filmcal: internal error while building the command line; this is a bug in "
                             "filmcal, please report it with the traceback above\n")
            return EXIT_INTERNAL
        if not argv:  # one line, as every refusal: the commands are in --help
            sys.stderr.write(f"filmcal: error: a command is required ({', '.join(command_modules())}; "
                             "filmcal --help says what each does)\n")
            return EXIT_USER
        take_notes()  # none of an earlier parse in this process
        args, unknown = parser.parse_known_args(argv)
    except KeyboardInterrupt:
        sys.stderr.write("filmcal: interrupted\n")
        return EXIT_INTERRUPTED
    if not getattr(args, "func", None):
        sys.stderr.write(f"filmcal: error: a command is required ({', '.join(command_modules())}; "
                         "filmcal --help says what each does)\n")
        return EXIT_USER
    path = [args.command] + ([args.action] if isinstance(getattr(args, "action", None), str) else [])
    prog = "filmcal " + " ".join(path)
    if unknown:
        # before the command's name they are the top level's
        first = next((i for i, a in enumerate(argv) if a == unknown[0]), len(argv))
        where = "filmcal" if first < argv.index(args.command) else prog
        message = unrecognized_message(_command_parser(parser, path if where == prog else []), where, unknown)
        sys.stderr.write(f"{where}: error: {_one_line(message)}\n")
        return EXIT_USER
    missing = missing_required(_command_parser(parser, path), args)
    if missing:
        sys.stderr.write(f"{prog}: error: the following arguments are required: {', '.join(missing)}\n")
        return EXIT_USER
    for note in take_notes():  # old spellings, said once the command line stands
        sys.stderr.write(note + "\n")
    actions = _command_actions(parser, path)
    options = _option_strings(actions)
    try:
        preflight(args, actions)
        check_workers_option(args, actions, path[0])
        with warnings.catch_warnings():
            _notes_as_one_line(prog)
            # an image above Pillow's pixel limit is refused, not decoded with a warning
            warnings.filterwarnings("error", message=r".*decompression bomb", category=RuntimeWarning)
            status = int(args.func(args) or 0)
        _say_notes(prog)
        return status
    except KeyboardInterrupt:
        _say_notes(prog)
        sys.stderr.write(f"{prog}: interrupted\n")
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # output piped into e.g. `head`
        try:
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - no flush error at exit
        except OSError:
            pass
        return EXIT_OK
    except Exception as exc:  # noqa: BLE001 - this is the boundary
        message = user_error_message(exc, args, options)
        if message is None:
            _say_notes(prog)
            traceback.print_exc(file=sys.stderr)
            sys.stderr.write(f"{prog}: internal error ({type(exc).__name__}); this is a bug in filmcal, "
                             "please report it with the traceback above\n")
            return EXIT_INTERNAL
        held_notes()  # a refusal is one line
        sys.stderr.write(f"{prog}: error: {message}\n")
        return EXIT_USER


if __name__ == "__main__":
    sys.exit(main())
