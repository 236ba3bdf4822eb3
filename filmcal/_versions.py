"""The versions of Python and of the packages that touch a study's numbers.

A study records them when it is made (`software_versions`); reading it under
other versions says so in one line (`version_note`), since the same seed can
give other digits with another numpy, scipy or ArviZ.
"""
from __future__ import annotations

import platform
from importlib import metadata

__all__ = ["__version__", "NUMERIC_PACKAGES", "software_versions", "version_note", "VersionNote", "hold_note",
           "held_notes"]

#: filmcal's own version (re-exported as ``filmcal.__version__``).
__version__ = "0.1.0"

#: Distributions whose releases can change a number filmcal computes.
NUMERIC_PACKAGES = ("numpy", "scipy", "scikit-learn", "scikit-fem", "emcee", "arviz", "h5py", "pyDOE")


class VersionNote(UserWarning):
    """A study is read under other versions than those that made it (one line for the user)."""


#: The notes a command met, each once, in order: the command line says them when the command has done its
#: work (or begins to serve), never beside the one line of a refusal.
_HELD: list[str] = []


def hold_note(text: str) -> None:
    """Keep a `VersionNote`'s text for `held_notes` (a text already kept is not kept twice)."""
    if text not in _HELD:
        _HELD.append(text)


def held_notes() -> list[str]:
    """The notes kept since the last call, forgotten here."""
    notes = list(_HELD)
    _HELD.clear()
    return notes


def software_versions() -> dict[str, str]:
    """``{"python": "3.11.7", "numpy": "2.4.6", ...}`` of this process (``"not installed"`` when missing)."""
    out = {"python": platform.python_version()}
    for name in NUMERIC_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def version_note(recorded: dict[str, str] | None, current: dict[str, str] | None = None) -> str | None:
    """One line naming what differs between the recorded and the current versions, or None.

    Parameters
    ----------
    recorded : dict or None
        Versions stored with a study (None: a study made before versions were recorded).
    current : dict, optional
        This process's versions (default `software_versions()`).
    """
    current = current if current is not None else software_versions()
    if not recorded:
        return ("made before filmcal recorded package versions; its numbers may differ in the last digits from "
                "a run of today's versions")
    diff = [f"{k} {recorded.get(k, '?')} (now {current.get(k, '?')})" for k in sorted(set(recorded) | set(current))
            if recorded.get(k) != current.get(k)]
    if not diff:
        return None
    return "made with " + ", ".join(diff) + "; numbers computed now may differ in the last digits"
