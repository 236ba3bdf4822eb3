"""Fuzzing every option of every command: bad values are refused before any work.

The cases are generated from the parser itself, so a new command or option is
covered without editing this file: every number option refuses non-finite and
non-numeric text, every size option refuses values outside its bounds (which
its help states), every choice option refuses an unknown choice, every path
option refuses a folder for a file, a file for a folder, a missing folder or a
missing input. The commands' work functions are replaced by a sentinel, so a
case that is not refused shows up as "work started" instead of running.
Each case asserts: exit status 2, exactly one line on stderr that names the
option, no traceback, nothing on stdout, no file written. One case of each kind
per command runs again as a user runs it, in a process without the sentinel.
"""
from __future__ import annotations

import argparse
import importlib
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from filmcal import cli
from filmcal.commands._options import bounds_text

PARSER = cli.build_parser()


def _leaves(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()) -> dict[tuple[str, ...], argparse.ArgumentParser]:
    out = {}
    for name, sub in cli._subparsers(parser).items():
        if cli._subparsers(sub):
            out.update(_leaves(sub, prefix + (name,)))
        else:
            out[prefix + (name,)] = sub
    return out


COMMANDS = _leaves(PARSER)


def _options(kind: str) -> list[tuple[tuple[str, ...], argparse.Action]]:
    cases = []
    for path, sub in COMMANDS.items():
        for action in sub._actions:
            if not action.option_strings or isinstance(action, argparse._HelpAction):
                continue
            name = getattr(action.type, "__name__", "")
            if kind == "number" and name in ("float", "int") and action.choices is None:
                cases.append((path, action))
            elif kind == "bounded" and getattr(action.type, "bounds", None) is not None:
                cases.append((path, action))
            elif kind == "choice" and action.choices is not None:
                cases.append((path, action))
    return cases


def _id(case) -> str:
    path, action = case
    return " ".join(path) + " " + action.option_strings[-1]


@pytest.fixture
def no_work(monkeypatch):
    """Replace every command's work function by a sentinel that records a start."""
    started: list[str] = []
    for name in cli.command_modules():
        module = importlib.import_module(f"filmcal.commands.{name}")
        monkeypatch.setattr(module, "run", lambda args, _n=name: started.append(_n) or 0)
    return started


def run(capsys, argv: list[str]) -> tuple[int, str, str]:
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse's own exits (usage errors, --help)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def assert_refused(code: int, out: str, err: str, *names: str) -> None:
    """Exit 2, one line on stderr naming one of `names`, no traceback, nothing on stdout."""
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert out == "", out
    if names:
        assert any(n in lines[0] for n in names), (names, lines[0])


# --- numbers, sizes, choices ------------------------------------------------------

NUMBER_OPTIONS = _options("number")
BOUNDED_OPTIONS = _options("bounded")
CHOICE_OPTIONS = _options("choice")


def test_the_suite_covers_every_command():
    covered = {path for path, _ in NUMBER_OPTIONS + CHOICE_OPTIONS}
    assert len(COMMANDS) >= 12 and len(NUMBER_OPTIONS) >= 40
    # every command with options of a kind is in the generated cases
    for path, sub in COMMANDS.items():
        if any(getattr(a.type, "__name__", "") in ("float", "int") or a.choices for a in sub._actions
               if a.option_strings and not isinstance(a, argparse._HelpAction)):
            assert path in covered, path


@pytest.mark.parametrize("case", NUMBER_OPTIONS, ids=_id)
@pytest.mark.parametrize("value", ["nan", "-inf", "1e999", "abc", "1_0", "\uff11"])  # 1_0 and a full-width 1 were 10, 1
def test_number_options_refuse_non_finite_and_text(capsys, no_work, tmp_path, monkeypatch, case, value):
    monkeypatch.chdir(tmp_path)
    path, action = case
    code, out, err = run(capsys, [*path, f"{action.option_strings[-1]}={value}"])
    assert_refused(code, out, err, action.option_strings[-1])
    assert not no_work and files_under(tmp_path) == set()


@pytest.mark.parametrize("case", BOUNDED_OPTIONS, ids=_id)
def test_size_options_refuse_values_outside_their_bounds_and_state_them(capsys, no_work, case):
    path, action = case
    low, high = action.type.bounds
    integer = action.type.__name__ == "int"
    below = low - 1 if integer else low / 2 if low > 0 else low - 1
    above = high + 1 if integer else high * 2
    values = [below, above] + (["1.5"] if integer else [])
    for value in values:
        code, out, err = run(capsys, [*path, f"{action.option_strings[-1]}={value}"])
        assert_refused(code, out, err, action.option_strings[-1])
    assert not no_work
    # the parser's own conversion accepts the bounds themselves and refuses just beyond them
    step = 1 if integer else 1e-9 * max(abs(low), abs(high), 1.0)
    for bound in (low, high):
        assert action.type(repr(bound)) == bound
    for beyond in (low - step, high + step):
        with pytest.raises((argparse.ArgumentTypeError, ValueError, TypeError)):
            action.type(repr(beyond))
    code, out, _ = run(capsys, [*path, "--help"])
    text = " ".join(out.split())
    shown = bounds_text(low, high, integer).strip()
    assert code == 0 and shown in text, (shown, text)


@pytest.mark.parametrize("case", CHOICE_OPTIONS, ids=_id)
def test_choice_options_refuse_unknown_choices(capsys, no_work, case):
    path, action = case
    for value in ["bogus", "", " " + str(action.choices[0] if isinstance(action.choices, (list, tuple))
                                          else sorted(action.choices)[0])]:
        code, out, err = run(capsys, [*path, f"{action.option_strings[-1]}={value}"])
        assert_refused(code, out, err, action.option_strings[-1])
    assert not no_work


GRID_OPTIONS = [(path, action) for path, sub in COMMANDS.items() for action in sub._actions
                if getattr(action.type, "max_count", None)]


@pytest.mark.parametrize("case", GRID_OPTIONS, ids=_id)
@pytest.mark.parametrize("value", ["-7:2:1e-7", "0:1e12:1", "abc", "", "1:0:1", "0:1:0", "0:1:-1", "nan,1",
                                   "1,inf", "a:b:c", "1:2", ",".join(["1"] * 1001)])
def test_list_and_range_options_are_bounded(capsys, no_work, case, value):
    path, action = case
    code, out, err = run(capsys, [*path, f"{action.option_strings[-1]}={value}"])
    assert_refused(code, out, err, action.option_strings[-1])
    assert not no_work


def test_list_options_state_their_bound(capsys):
    assert GRID_OPTIONS
    for path, action in GRID_OPTIONS:
        code, out, _ = run(capsys, [*path, "--help"])
        assert f"at most {action.type.max_count} values" in " ".join(out.split())


NUMBERS_BY_COMMAND = {}
for _path, _action in NUMBER_OPTIONS:
    NUMBERS_BY_COMMAND.setdefault(_path, []).append(_action.option_strings[-1])


def _not_a_number(text: str) -> bool:
    try:
        import math
        return not math.isfinite(float(text))
    except ValueError:
        return True


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_property_any_non_number_is_refused_naming_the_option(capsys, no_work, data):
    path = data.draw(st.sampled_from(sorted(NUMBERS_BY_COMMAND)))
    option = data.draw(st.sampled_from(NUMBERS_BY_COMMAND[path]))
    value = data.draw(st.one_of(
        st.text(min_size=0, max_size=12).filter(_not_a_number),
        st.sampled_from(["nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-1e400", "", "0x10"]),
    ))
    code, out, err = run(capsys, [*path, f"{option}={value}"])
    assert_refused(code, out, err, option)
    assert not no_work


@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_property_sizes_outside_bounds_are_refused(capsys, no_work, data):
    path, action = data.draw(st.sampled_from(BOUNDED_OPTIONS))
    low, high = action.type.bounds
    if action.type.__name__ == "int":
        value = data.draw(st.one_of(st.integers(max_value=int(low) - 1), st.integers(min_value=int(high) + 1)))
    else:
        value = data.draw(st.one_of(
            st.floats(max_value=low, exclude_max=True, allow_nan=False, allow_infinity=False),
            st.floats(min_value=high, exclude_min=True, allow_nan=False, allow_infinity=False)))
    code, out, err = run(capsys, [*path, f"{action.option_strings[-1]}={value!r}"])
    assert_refused(code, out, err, action.option_strings[-1])
    assert not no_work


# --- path options ---------------------------------------------------------------------

def base_argv(path: tuple[str, ...], tmp: Path) -> list[str]:
    """Required options of each command with harmless values (the work never runs)."""
    design = tmp / "in" / "design.csv"
    store = tmp / "in" / "runs.sqlite"
    base = {
        ("fem",): ["--sphere-radius-mm", "450", "--force-kn", "75", "--no-film"],
        ("doe",): ["--samples", "5", "--param", "a=0:1", "--out", str(tmp / "d.csv")],
        ("campaign", "run"): ["--design", str(design), "--store", str(tmp / "r.sqlite")],
        ("campaign", "status"): ["--store", str(store)],
        ("campaign", "export"): ["--store", str(store), "--out", str(tmp / "e.csv")],
        ("calibrate",): ["--film", "HS"],
        ("profile",): ["S1002"],
        ("wheelrail",): ["--offset-mm=-3", "--force-kn", "100", "--no-film"],
        ("correct",): ["--film", "HS", "--force-kn", "100", "--measured-area-mm2", "150", "--offset-mm=-3"],
        ("curves",): ["--film", "HS"],
        ("report",): [],
        ("scan",): [str(design), "--out", str(tmp / "s.csv")],
    }
    return list(base.get(path, []))


def _path_cases() -> list[tuple[tuple[str, ...], argparse.Action, str]]:
    cases = []
    for path, sub in COMMANDS.items():
        for action in sub._actions:
            if not action.option_strings or action.choices is not None or action.type not in (None, str):
                continue
            if action.nargs == 0 or isinstance(action, argparse._AppendAction):
                continue
            if action.dest in cli.OUTPUT_FILE_DESTS:
                cases.append((path, action, "file"))
            elif action.dest in cli.OUTPUT_DIR_DESTS:
                cases.append((path, action, "dir"))
            elif action.dest in cli.INPUT_FILE_DESTS or action.dest == "store":
                cases.append((path, action, "input"))
    return cases


PATH_CASES = _path_cases()


@pytest.fixture
def inputs(tmp_path):
    """A folder `in` with a design, a store-like file and a plain file; a folder `adir`."""
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "design.csv").write_text("modulus_mpa,poisson,radius_mm,force_kn\n2800,0.33,450,75\n")
    (tmp_path / "in" / "runs.sqlite").write_bytes(b"")
    (tmp_path / "in" / "plain.txt").write_text("x\n")
    (tmp_path / "adir").mkdir()
    return tmp_path


@pytest.mark.parametrize("case", PATH_CASES, ids=lambda c: " ".join(c[0]) + " " + c[1].option_strings[-1])
def test_path_options_are_checked_before_any_work(capsys, no_work, inputs, case):
    path, action, kind = case
    tmp = inputs
    opt = action.option_strings[-1]
    base = base_argv(path, tmp)
    # drop the option from the base argv, then give it bad values
    if opt in base:
        i = base.index(opt)
        del base[i:i + 2]
    plain = str(tmp / "in" / "plain.txt")
    bad = {
        "file": [str(tmp / "adir"), str(tmp / "missing-folder" / "x.csv"), plain + "/x.csv"],
        "dir": [plain, str(tmp / "missing" / "deeper")],
        "input": [str(tmp / "adir"), str(tmp / "missing.csv")],
    }[kind]
    if kind == "input" and action.dest == "store" and path[-1] == "run":
        bad = [str(tmp / "adir"), str(tmp / "missing-folder" / "r.sqlite")]
    before = files_under(tmp)
    for value in bad:
        code, out, err = run(capsys, [*path, *base, opt, value])
        assert_refused(code, out, err, opt)
        assert files_under(tmp) == before
    assert not no_work


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs /proc")
@pytest.mark.parametrize("argv", [
    ["campaign", "run", "--design", "{design}", "--store", "/proc/x.sqlite"],
    ["doe", "--samples", "5", "--param", "a=0:1", "--out", "/proc/design.csv"],
    ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--no-film", "--plot", "/proc/p.png"],
    ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--no-film", "--plot", "{tmp}/p.txt"],
    ["profile", "S1002", "--plot", "{tmp}/adir"],
])
def test_unwritable_or_odd_outputs(capsys, no_work, inputs, argv):
    argv = [a.format(design=inputs / "in" / "design.csv", tmp=inputs) for a in argv]
    code, out, err = run(capsys, argv)
    assert_refused(code, out, err, "--store", "--out", "--plot")
    assert not no_work


# --- the command line as a whole ------------------------------------------------------

def test_option_cases_of_every_command_as_processes(tmp_path):
    """A non-finite number, a size below its bound and an unknown choice for every command that has them, as a
    user runs it (``python -m filmcal.cli``: no sentinel, so a case that is not refused would start its work;
    each in a process and an empty working folder of its own, four at a time): exit 2, one stderr line naming
    the option, nothing on stdout, nothing written."""
    import subprocess
    import sys
    from concurrent.futures import ThreadPoolExecutor

    cases: dict[tuple, list] = {}
    for kind, options in (("number", NUMBER_OPTIONS), ("bounded", BOUNDED_OPTIONS), ("choice", CHOICE_OPTIONS)):
        for path, action in options:
            if (path, kind) in cases:
                continue
            if kind == "number":
                value = "nan"
            elif kind == "bounded":
                low = action.type.bounds[0]
                value = repr(low - 1 if action.type.__name__ == "int" else low / 2 if low > 0 else low - 1)
            else:
                value = "bogus"
            cases[(path, kind)] = [*path, f"{action.option_strings[-1]}={value}"]

    def one(k: int, argv: list[str]) -> str | None:
        where = tmp_path / f"case{k}"
        where.mkdir()
        try:
            p = subprocess.run([sys.executable, "-m", "filmcal.cli", *argv], capture_output=True, text=True,
                               stdin=subprocess.DEVNULL, timeout=60, cwd=where)
        except subprocess.TimeoutExpired:
            return f"{' '.join(argv)}: ran past 60 s instead of refusing its input"
        lines = [line for line in p.stderr.splitlines() if line.strip()]
        option = argv[-1].split("=", 1)[0]
        if p.returncode != 2 or len(lines) != 1 or p.stdout or option not in lines[0]:
            return f"{' '.join(argv)}: exit {p.returncode}, stderr {p.stderr.strip()[-300:]!r}, stdout {p.stdout[:100]!r}"
        if files_under(where):
            return f"{' '.join(argv)}: wrote {sorted(files_under(where))}"
        return None

    with ThreadPoolExecutor(4) as pool:
        failures = [f for f in pool.map(lambda kc: one(*kc), enumerate(cases.values())) if f]
    assert len({path for path, _ in cases}) >= 10 and not failures, "\n".join(failures[:20])


def test_bare_filmcal_prints_one_line_on_stderr_and_exits_2(capsys):
    code, out, err = run(capsys, [])
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and err.startswith("filmcal: error: a command is required")


def test_unknown_command_and_option(capsys, no_work):
    code, out, err = run(capsys, ["frobnicate"])
    assert_refused(code, out, err, "frobnicate")
    code, out, err = run(capsys, ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--no-film", "--bogus"])
    assert_refused(code, out, err, "--bogus")
    code, out, err = run(capsys, ["campaign"])
    assert_refused(code, out, err, "ACTION")
    assert not no_work


@pytest.mark.parametrize("path", [()] + sorted(COMMANDS) + [("campaign",)], ids=lambda p: " ".join(p) or "filmcal")
def test_help_pages_show_percent_signs_singly(capsys, path):
    code, out, err = run(capsys, [*path, "--help"])
    assert code == 0 and out.startswith("usage: filmcal")
    assert "%%" not in out and "%(" not in out
