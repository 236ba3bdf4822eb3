"""The command line as a whole: every subcommand is discovered and explains itself."""
from __future__ import annotations

import pkgutil
import subprocess
import sys

import pytest

import filmcal.commands

SUBCOMMANDS = sorted(m.name for m in pkgutil.iter_modules(filmcal.commands.__path__) if not m.name.startswith("_"))


def test_top_level_help_lists_every_subcommand():
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "--help"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert len(SUBCOMMANDS) >= 10
    for name in SUBCOMMANDS:
        assert f"\n    {name}" in p.stdout, name


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_subcommand_help(name):
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", name, "--help"], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0 and "usage: filmcal " + name in p.stdout, p.stderr


def test_every_size_bound_is_used_and_stated():
    """Each bound of `cli.SIZE_BOUNDS` belongs to an option of some command, whose help states it."""
    import argparse

    from filmcal import cli
    from filmcal.commands._options import bounds_text

    parser = cli.build_parser()
    seen = set()

    def walk(p):
        for sub in cli._subparsers(p).values():
            walk(sub)
            for action in sub._actions:
                if action.dest in cli.SIZE_BOUNDS and getattr(action.type, "bounds", None):
                    seen.add(action.dest)
                    low, high = action.type.bounds
                    integer = isinstance(low, int) and isinstance(high, int)
                    assert action.help and bounds_text(low, high, integer).strip() in action.help, action.help
    walk(parser)
    assert isinstance(parser, argparse.ArgumentParser)
    assert seen == set(cli.SIZE_BOUNDS), set(cli.SIZE_BOUNDS) - seen


def test_lock_and_busy_files_are_not_called_damaged(tmp_path):
    import argparse

    from filmcal import cli

    busy = OSError(f"[Errno 11] Unable to synchronously open file (unable to lock file, errno = 11, "
                   f"error message = 'Resource temporarily unavailable') (name = '{tmp_path / 'HS.h5'}')")
    line = cli.user_error_message(busy, argparse.Namespace(), {})
    assert "in use by another process" in line and "HS.h5" in line and "damaged" not in line


def test_every_checked_path_option_exists():
    """The path options checked before work name options that some command has (no stale names)."""
    from filmcal import cli

    parser = cli.build_parser()
    dests = set()

    def walk(p):
        for sub in cli._subparsers(p).values():
            walk(sub)
            dests.update(a.dest for a in sub._actions)
    walk(parser)
    for name in (*cli.OUTPUT_FILE_DESTS, *cli.OUTPUT_DIR_DESTS, *cli.INPUT_FILE_DESTS, *cli.GRID_BOUNDS):
        assert name in dests, name


def test_no_command_is_one_line_naming_the_commands(capsys):
    from filmcal import cli

    assert cli.main([]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pipeline" in err[0] and "correct" in err[0]



@pytest.mark.parametrize("argv, says", [
    (["correct", "--film", "HS", "--force-kn", "10", "--measured-area-mm2", "100", "--ofset-mm", "0"],
     "filmcal correct: error: unrecognized arguments: --ofset-mm 0 (--ofset-mm: did you mean --offset-mm?; "
     "`filmcal correct --help` lists its options)"),
    (["curves", "--film", "HS", "--out", "c.csv"],
     "filmcal curves: error: unrecognized arguments: --out c.csv (`filmcal curves --help` lists its options)"),
    (["campaign", "status", "--store", "s", "--jsno"], "filmcal campaign status: error: unrecognized arguments: --jsno "
                                              "(--jsno: did you mean --json?;")])
def test_an_unknown_argument_is_named_by_its_command_with_the_nearest_option(argv, says, capsys):
    """They were refused as 'filmcal: error: unrecognized arguments', naming neither the command nor a
    nearby option; nothing is run."""
    from filmcal import cli

    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1
    assert captured.err.startswith(says), captured.err

@pytest.mark.parametrize("wrapped", [False, True])
def test_a_full_disk_is_named_and_never_called_damage(wrapped):
    """A full disk was reported as "study.json is damaged (No space left on device); delete it and rerun"."""
    import argparse
    import errno

    from filmcal import cli
    from filmcal._errors import DamagedFileError

    full = OSError(errno.ENOSPC, "No space left on device", "study/study.json")
    exc = full
    if wrapped:  # as a reader that wraps what it met
        try:
            try:
                raise full
            except OSError as inner:
                raise DamagedFileError("study/study.json", "No space left on device") from inner
        except DamagedFileError as outer:
            exc = outer
    message = cli.user_error_message(exc, argparse.Namespace(), {})
    assert "no space left" in message and "damaged" in message and "delete" not in message
    assert "no file was damaged" in message


def test_a_read_only_study_can_be_read(tmp_path, monkeypatch):
    """`correct`, `curves` and `report` refused a colleague's read-only study as 'not writable'."""
    import filmcal._io
    from filmcal._errors import InputError
    from filmcal.study import Study

    with Study(tmp_path / "s", create=True).writing("test"):
        pass
    monkeypatch.setattr(filmcal._io, "_can_create_in", lambda path: False)  # as a read-only folder answers
    assert Study(tmp_path / "s").manifest.data["format"] == "filmcal-study/1"  # opened for reading
    with pytest.raises(InputError, match="not writable"):
        Study(tmp_path / "s", create=True)  # a writer is still refused before any work


def test_the_old_progress_value_is_noted_by_its_command(tmp_path, capsys):
    """`--progress live` said 'filmcal: note: ...' from whichever command it was given to."""
    from filmcal import cli

    assert cli.main(["curves", "--film", "HS", "--study-dir", str(tmp_path / "none"), "--progress", "live"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == ("filmcal curves: note: --progress live is renamed --progress bar; the old name goes in the "
                      "next release")
