"""One name per concept in every command, JSON key and CSV column.

The concept -> option map is derived from `filmcal.commands._options` (the shared vocabulary that every
command builds its options from), and the second names from the hidden aliases that the commands register
for their old spellings: no visible option, JSON key or CSV column may use one of those.
"""
from __future__ import annotations

import argparse
import json

import pytest

from filmcal import cli
from filmcal.commands import _options as vocab


def _parsers():
    parser = cli.build_parser()
    out = {}

    def walk(p, path):
        for name, sub in cli._subparsers(p).items():
            out[" ".join([*path, name])] = sub
            walk(sub, [*path, name])
    walk(parser, [])
    return {k: v for k, v in out.items() if not cli._subparsers(v)}


PARSERS = _parsers()


def _visible(sub: argparse.ArgumentParser):
    return [a for a in sub._actions if a.option_strings and a.help is not argparse.SUPPRESS
            and not isinstance(a, argparse._HelpAction)]


def _old_names() -> dict[str, str]:
    """Old spelling (as a Python name) -> what replaces it, from every command's hidden aliases."""
    old = {}
    for sub in PARSERS.values():
        for a in sub._actions:
            new = getattr(a, "filmcal_renamed", None)
            if new is not None:
                for flag in a.option_strings:
                    old[flag.lstrip("-").replace("-", "_")] = new
    return old


OLD = _old_names()


def test_the_vocabulary_knows_the_old_names():
    # the test below could not fail if no command registered an old spelling
    assert {"radius_mm", "large_strain", "film_type", "loads", "rough_ra_um", "roughness_ra_um"} <= set(OLD)
    assert all(name not in vocab.VOCABULARY for name in OLD)


@pytest.mark.parametrize("command", sorted(PARSERS))
def test_every_option_is_a_concept_or_a_local_option_and_none_is_an_old_name(command):
    for action in _visible(PARSERS[command]):
        concept = vocab.concept_of(action)
        flag = action.option_strings[0]
        if concept is not None:
            assert flag == vocab.VOCABULARY[concept].flag, (command, flag, concept)
            assert action.dest == concept, (command, flag)
        else:
            assert getattr(action, "filmcal_local", False), (
                f"{command} {flag}: built with add_argument; use _options.add (a concept) or _options.local")
            assert action.dest not in vocab.VOCABULARY, f"{command} {flag}: {action.dest} is a concept"
        assert action.dest not in OLD, f"{command} {flag}: {action.dest} is the old name of {OLD[action.dest]}"


def test_an_option_added_outside_the_vocabulary_is_caught():
    p = argparse.ArgumentParser()
    rogue = p.add_argument("--radius-mm", type=float)
    assert vocab.concept_of(rogue) is None and not getattr(rogue, "filmcal_local", False)
    with pytest.raises(AssertionError):
        vocab.local(p, "--sphere-radius-mm")


def _keys(value, prefix=""):
    """Every key of a JSON value (nested objects and lists of objects included)."""
    if isinstance(value, dict):
        for k, v in value.items():
            yield k
            yield from _keys(v)
    elif isinstance(value, list):
        for v in value:
            yield from _keys(v)


JSON_COMMANDS = [
    ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--film-modulus-mpa", "2800", "--film", "HS",
     "--imprint-model", "capsule", "--json"],
    ["wheelrail", "--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--film", "HS",
     "--grid-mm", "0.2", "--json"],
    ["doe", "--samples", "5", "--param", "modulus_mpa=500:5000", "--param", "sphere_radius_mm=300,450",
     "--out", "{tmp}/d.csv", "--json"],
    ["profile", "60E2", "--step-mm", "1", "--json"],
]


@pytest.mark.parametrize("argv", JSON_COMMANDS, ids=lambda a: a[0])
def test_json_keys_use_no_old_name(argv, tmp_path, capsys):
    assert cli.main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 0
    out, _ = capsys.readouterr()
    keys = set(_keys(json.loads(out)))
    assert keys, argv
    bad = sorted(k for k in keys if k in OLD)
    assert not bad, f"{argv[0]} --json uses old names {bad} (now {[OLD[k] for k in bad]})"


def test_csv_columns_use_no_old_name():
    from filmcal.calibration.datasets import MEASURED_COLUMNS, OPTIONAL_COLUMNS, REQUIRED_COLUMNS
    from filmcal.commands.campaign import COLUMN_CHECKS
    from filmcal.contact.options import COLUMNS
    from filmcal.correction import CURVE_COLUMNS
    from filmcal.surrogate.radius import INPUTS

    for name, columns in (("campaign design", COLUMN_CHECKS), ("FE options", COLUMNS), ("curves", CURVE_COLUMNS),
                          ("surrogate inputs", INPUTS), ("dataset", REQUIRED_COLUMNS + MEASURED_COLUMNS + OPTIONAL_COLUMNS)):
        bad = sorted(c for c in columns if c in OLD)
        assert not bad, f"{name} columns use old names {bad}"


def test_no_example_or_bench_script_takes_an_old_option_name():
    """The scripts a lab copies speak the commands' vocabulary too (they took --loads, --rough-ra-um, --model
    IMPRINT/KINEMATICS, --radius-mm and --large-strain). A bench's --model names a compared model by its label
    (edge/small), the summary's own key, not the renamed option."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    scripts = [*root.glob("examples/**/*.py"), *root.glob("bench/**/*.py")]
    assert len(scripts) > 10
    bad = [f"{path.relative_to(root)}: --{flag}" for path in scripts
           for flag in re.findall(r'add_argument\(\s*"--([a-z0-9-]+)"', path.read_text())
           if flag.replace("-", "_") in OLD and not (flag == "model" and path.parent.name == "bench")]
    assert not bad, bad
