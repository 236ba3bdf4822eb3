"""Any simulator in the loop: an external command run once per design point.

`CommandModel` is a campaign model built from a shell command template, as
design-exploration tools drive Abaqus or any other solver::

    python3 sim.py --e {modulus_mpa} --r {sphere_radius_mm}

For every point it

1. makes a fresh working folder ``<work_root>/<point_id>/`` (a leftover of an
   interrupted attempt is removed first; the folder is kept afterwards so
   that the solver's files can be inspected),
2. renders the input template files into it (``deck.inp.tmpl`` becomes
   ``deck.inp``), with ``{column}`` replaced by the point's values,
3. runs the command with ``/bin/sh -c`` in that folder, each placeholder
   replaced by its value quoted for the shell (`shlex.quote`), with a
   deadline after which the command's whole process group is killed,
4. reads its outputs: ``outputs.json`` in the folder if the command wrote
   one, else the JSON object it printed on stdout (the whole of stdout, or
   else its last line that is a JSON object). The object's numeric values
   (and booleans) are the run's outputs; other values are ignored.

A non-zero exit status, a timeout, output that holds no JSON object, no
numeric value, or NaN makes a failed run whose reason ends with the tail of
the command's stderr. stdout and stderr are kept in the folder as
``stdout.txt`` and ``stderr.txt``.

The run ends when the command's own process exits: a background process it
leaves behind is killed then, also one that left the process group with
``setsid`` (on Linux: every process started with the run's mark,
``FILMCAL_RUN_MARK``, in its environment; a helper meant to outlive the run,
such as a licence server, is started without it: ``env -u FILMCAL_RUN_MARK
server &``; one that escapes does not hold up the campaign). filmcal reads
only the last 16 MiB (`filmcal._parallel.OUTPUT_CAP_BYTES`) of stdout and of
stderr: of a longer stream, ``stdout.txt`` or ``stderr.txt`` holds that end,
after a first line that gives the size written. A command that prints more
than that on stdout, and writes no ``outputs.json``, makes a failed run (its
answer is not read from part of its output): write large output to files,
and the answer to ``outputs.json``.

Placeholders are ``{name}`` with ``name`` a design column; ``{point_id}``
and ``{work_dir}`` are also available. Other braces (``awk '{print $1}'``)
are left as they are. Do not put a placeholder inside quotes in the
template: its value is quoted already. Numbers are written in the shortest
form that reads back to the same float (``450``, ``0.33``, ``2.5e-05``).
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shlex
import shutil
import signal
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from filmcal._errors import InputError
from filmcal._parallel import guarded, run_guarded
from filmcal.campaign.design import DesignValue

__all__ = ["ModelFailure", "CommandModel", "render_template", "placeholders_of", "parse_outputs"]

PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")
BUILTIN_PLACEHOLDERS = ("point_id", "work_dir")
OUTPUTS_FILE = "outputs.json"
TEMPLATE_SUFFIX = ".tmpl"
_TAIL_LINES = 5
_TAIL_CHARS = 400


class ModelFailure(Exception):
    """A model run that failed for a stated reason (stored as the run's reason as is)."""


def placeholders_of(text: str) -> list[str]:
    """Names of the ``{name}`` placeholders in `text`, in order of first appearance."""
    return list(dict.fromkeys(PLACEHOLDER.findall(text)))


def format_value(value: DesignValue) -> str:
    """A design value as text: numbers in shortest round-trip form, booleans as true/false."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if value.is_integer() and abs(value) < 1e16:
            return str(int(value))
        return repr(value)
    if isinstance(value, int):
        return str(value)
    return str(value)


def render_template(text: str, values: Mapping[str, DesignValue], *, quote: bool) -> str:
    """Replace the ``{name}`` placeholders of `text` by their values.

    Parameters
    ----------
    text : str
        The template.
    values : mapping
        Value of each placeholder.
    quote : bool
        Quote each value for the shell (`shlex.quote`): for command lines.

    Raises
    ------
    KeyError
        If a placeholder has no value.
    """
    def substitute(match: re.Match) -> str:
        rendered = format_value(values[match.group(1)])
        return shlex.quote(rendered) if quote else rendered

    return PLACEHOLDER.sub(substitute, text)


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def _exit_text(code: int) -> str:
    """An exit status in words; the shell reports a child killed by signal N as 128 + N."""
    if code < 0:
        return f"killed by signal {-code} ({_signal_name(-code)})"
    if 128 < code <= 128 + 64:
        return f"exit status {code}: killed by signal {code - 128} ({_signal_name(code - 128)})"
    return f"exit status {code}"


def _size_text(n_bytes: int) -> str:
    """A size in bytes as text: ``1000 bytes``, ``4.9 KiB``, ``400 MiB``, ``1.2 GiB``."""
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n_bytes >= scale:
            return f"{n_bytes / scale:.1f}".removesuffix(".0") + " " + unit
    return f"{n_bytes} bytes"


def _kept_output(text: str, truncated: bool, n_bytes: int) -> str:
    """An output stream as saved in the point's folder: a truncated one says so on its first line."""
    if not truncated:
        return text
    return (f"[filmcal: the command wrote {_size_text(n_bytes)} here; only the last "
            f"{_size_text(guarded.OUTPUT_CAP_BYTES)} were read and are kept below]\n{text}")


def _tail(text: str) -> str:
    lines = [line.strip() for line in text.strip().splitlines() if line.strip()]
    tail = " | ".join(lines[-_TAIL_LINES:])
    return tail if len(tail) <= _TAIL_CHARS else "..." + tail[-_TAIL_CHARS:]


def _json_object(stdout: str) -> dict[str, Any] | None:
    """The JSON object printed on stdout: all of it, or else its last line that is one."""
    text = stdout.strip()
    candidates = [text] + [line.strip() for line in reversed(text.splitlines()) if line.strip().startswith("{")]
    for candidate in candidates:
        try:
            obj = json.loads(candidate)
        except (ValueError, RecursionError):
            continue
        if isinstance(obj, dict):
            return obj
    return None


def parse_outputs(obj: Mapping[str, Any], arrays: Sequence[str] = ()) -> dict[str, Any]:
    """The numeric (and boolean) values of a command's JSON object; a ``reason`` string is kept too, and the
    lists of numbers named in `arrays`.

    Raises
    ------
    ModelFailure
        If there is no numeric value.
    """
    outputs: dict[str, Any] = {}
    for name, value in obj.items():
        if isinstance(value, bool) or (isinstance(value, (int, float))):
            outputs[str(name)] = value if isinstance(value, bool) else float(value)
        elif name in arrays and isinstance(value, list):
            if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise ModelFailure(f"{name} must be a list of numbers")
            outputs[str(name)] = [float(v) for v in value]
    if not any(isinstance(v, float) for v in outputs.values()):
        raise ModelFailure(f"the command's JSON object has no numeric value (keys: {', '.join(map(str, obj)) or 'none'})")
    if outputs.get("converged") is False and isinstance(obj.get("reason"), str):
        outputs["reason"] = obj["reason"]
    return outputs


@dataclass(frozen=True)
class CommandModel:
    """A campaign model that runs an external command per design point.

    Parameters
    ----------
    template : str
        Shell command with ``{column}`` placeholders (see the module docstring).
    work_root : path-like
        Folder under which each point gets its working folder ``<point_id>/``.
    template_files : sequence of (str, str)
        ``(file name, template text)`` of the input files rendered into each
        working folder (use `from_files` to read them from disk).
    timeout_s : float, optional
        Deadline of each run; the command's process group is killed at it.
    arrays : tuple of str
        Outputs kept when they are lists of numbers (a profile); other lists are dropped.

    Examples
    --------
    >>> model = CommandModel.from_files("python3 sim.py --e {modulus_mpa}", "runs.work",
    ...                                 ["deck.inp.tmpl"], timeout_s=600)  # doctest: +SKIP
    >>> model({"modulus_mpa": 2800.0}, point_id="p1")  # doctest: +SKIP
    {'contact_radius_mm': 6.4}
    """

    template: str
    work_root: Path
    template_files: tuple[tuple[str, str], ...] = ()
    timeout_s: float | None = None
    arrays: tuple[str, ...] = ()
    takes_point_id: ClassVar[bool] = True
    model_name: str = field(init=False)

    @property
    def enforces_timeout(self) -> bool:
        """True if the command is killed at its own deadline (the executor's is then a backstop)."""
        return self.timeout_s is not None

    def __post_init__(self) -> None:
        if not isinstance(self.template, str) or not self.template.strip():
            raise InputError("--simulator-command must be a non-empty command template")
        object.__setattr__(self, "work_root", Path(self.work_root))
        object.__setattr__(self, "template_files", tuple((str(n), str(t)) for n, t in self.template_files))
        names = [name for name, _ in self.template_files]
        bad = [name for name in names if not name or Path(name).name != name or name in (OUTPUTS_FILE, "stdout.txt", "stderr.txt")]
        if bad:
            raise InputError(f"--template-file: cannot render into the file name(s) {', '.join(map(repr, bad))}")
        if len(set(names)) != len(names):
            raise InputError(f"--template-file: two template files render to the same name ({', '.join(names)})")
        if self.timeout_s is not None and not (0 < float(self.timeout_s) < math.inf):
            raise InputError(f"--timeout-s must be a finite number > 0, got {self.timeout_s!r}")
        object.__setattr__(self, "model_name", "command: " + self.template)

    @classmethod
    def from_files(cls, template: str, work_root: str | os.PathLike, template_paths: Iterable[str | os.PathLike] = (),
                   timeout_s: float | None = None) -> "CommandModel":
        """Build the model, reading each template file (``NAME.tmpl`` is rendered as ``NAME``).

        Raises
        ------
        filmcal._errors.InputError
            If a template file is missing, a folder, or not UTF-8 text.
        """
        files = []
        for path in map(Path, template_paths):
            if not path.is_file():
                raise InputError(f"--template-file {str(path)!r} does not exist or is not a file")
            try:
                text = path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise InputError(f"--template-file {str(path)!r} cannot be read as UTF-8 text ({exc})") from None
            name = path.name[: -len(TEMPLATE_SUFFIX)] if path.name.endswith(TEMPLATE_SUFFIX) else path.name
            files.append((name, text))
        return cls(template, Path(work_root), tuple(files), timeout_s)

    @property
    def placeholders(self) -> list[str]:
        """The design columns the command and the template files refer to (built-ins excluded)."""
        names = placeholders_of(self.template)
        for _, text in self.template_files:
            names += placeholders_of(text)
        return [name for name in dict.fromkeys(names) if name not in BUILTIN_PLACEHOLDERS]

    def settings(self) -> dict[str, Any]:
        """What changes the outputs besides the design: the template files' contents (hashed)."""
        return {"template_files": {name: hashlib.sha256(text.encode()).hexdigest()
                                   for name, text in self.template_files}}

    def check_design(self, points: Sequence[Mapping[str, DesignValue]]) -> None:
        """Check, before any run, that every point has a value for every placeholder.

        Raises
        ------
        filmcal._errors.InputError
            Naming the missing column and the first row that lacks it.
        """
        for row, point in enumerate(points, start=1):
            missing = [name for name in self.placeholders if name not in point]
            if missing:
                raise InputError(f"design row {row} has no value for placeholder(s) "
                                 f"{', '.join('{' + m + '}' for m in missing)} of --simulator-command/--template-file")

    def __call__(self, params: Mapping[str, DesignValue], point_id: str | None = None) -> dict[str, Any]:
        """Run the command for one point; return its outputs.

        Raises
        ------
        ModelFailure
            Non-zero exit, timeout, no JSON object, no numeric value, or
            more output on stdout than filmcal reads when the answer is to be
            read from it (no ``outputs.json``); the message ends with the tail
            of stderr.
        """
        if point_id is None:
            point_id = hashlib.sha256(json.dumps(dict(params), sort_keys=True).encode()).hexdigest()[:16]
        # the point's own folder, never what a link in its place points to: a link (or a file) there is
        # removed as such, and only a real folder of the work root is emptied
        work_dir = self.work_root.resolve() / point_id
        if work_dir.is_symlink() or work_dir.is_file():
            work_dir.unlink()
        elif work_dir.exists():
            shutil.rmtree(work_dir)
        work_dir.mkdir(parents=True)
        values: dict[str, DesignValue] = {**params, "point_id": point_id, "work_dir": str(work_dir)}
        for name, text in self.template_files:
            (work_dir / name).write_text(render_template(text, values, quote=False), encoding="utf-8")
        command = render_template(self.template, values, quote=True)
        env = {**os.environ, "FILMCAL_POINT_ID": point_id, "FILMCAL_WORK_DIR": str(work_dir)}
        run = run_guarded(command, shell=True, cwd=work_dir, timeout_s=self.timeout_s, env=env)
        (work_dir / "stdout.txt").write_text(_kept_output(run.stdout, run.stdout_truncated, run.stdout_bytes),
                                             encoding="utf-8")
        (work_dir / "stderr.txt").write_text(_kept_output(run.stderr, run.stderr_truncated, run.stderr_bytes),
                                             encoding="utf-8")
        stderr = _tail(run.stderr)
        said = f"; stderr: {stderr}" if stderr else ""
        if run.timed_out:
            raise ModelFailure(f"timeout after {self.timeout_s:g} s{said}")
        if run.returncode != 0:
            raise ModelFailure(f"command failed ({_exit_text(run.returncode)}){said}")
        outputs_file = work_dir / OUTPUTS_FILE
        if outputs_file.is_file():
            try:
                obj = json.loads(outputs_file.read_text(encoding="utf-8"))
            except (ValueError, UnicodeDecodeError) as exc:
                raise ModelFailure(f"{OUTPUTS_FILE} is not JSON ({exc}){said}") from None
            if not isinstance(obj, dict):
                raise ModelFailure(f"{OUTPUTS_FILE} holds a {type(obj).__name__}, not a JSON object{said}")
        else:
            if run.stdout_truncated:  # its JSON object cannot be told from a part of one
                raise ModelFailure(f"the command wrote {_size_text(run.stdout_bytes)} on stdout, more than the "
                                   f"{_size_text(guarded.OUTPUT_CAP_BYTES)} filmcal reads (write the outputs "
                                   f"to {OUTPUTS_FILE} instead, or print less){said}")
            obj = _json_object(run.stdout)
            if obj is None:
                shown = _tail(run.stdout) or "nothing"
                raise ModelFailure(f"the command printed no JSON object (stdout: {shown}){said}")
        try:
            return parse_outputs(obj, self.arrays)
        except ModelFailure as exc:
            raise ModelFailure(f"{exc}{said}") from None
