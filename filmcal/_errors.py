"""The package's error taxonomy.

Two kinds of failure are the user's to fix, and both are `ValueError`
subclasses so that library code that raises or catches `ValueError` keeps
working:

- `InputError`: a parameter or option outside its allowed range, an unknown
  name, an inconsistent combination. The message names the parameter.
- `UntrustedArtefactError` (an `InputError`): a study artefact that is not
  the file the study wrote: changed after it was written, of another kind or
  spec than recorded, unrecorded, or reached through a link out of the study.
  Every command refuses it, even those that otherwise report what they could
  read.
- `DamagedFileError`: a file that exists but cannot be read as what it should
  be (truncated JSON, a garbled SQLite store, a broken npz, HDF5 or image).
  The message names the file and what to do: for a file the package made
  itself and can make again, that deleting it makes the next run recompute
  it; for a record that cannot be recomputed (a study's manifest), its own
  advice.

The command line (`filmcal.cli.main`) turns both, and the operating-system
errors of the user's paths, into one line on stderr and exit status 2.
Anything else is an internal error: a traceback and exit status 70.
"""
from __future__ import annotations

from os import PathLike

__all__ = ["InputError", "UntrustedArtefactError", "DamagedFileError", "damaged"]


class InputError(ValueError):
    """A user input (parameter, option, combination) outside what is allowed."""


class UntrustedArtefactError(InputError):
    """A study artefact that is not what the study's manifest recorded (see the module's notes)."""


class DamagedFileError(ValueError):
    """A file that exists but cannot be read as what it should be.

    Parameters
    ----------
    path : str or os.PathLike
        The damaged file.
    reason : str
        What is wrong with it (one line).
    recomputable : bool, optional
        True for a file the package wrote itself (a study artefact): the
        message then says that deleting it makes the next run recompute it.
    advice : str, optional
        What to do, in place of the advice `recomputable` chooses (for a
        file whose loss would lose more than itself).
    """

    def __init__(self, path: str | PathLike, reason: str, recomputable: bool = False,
                 advice: str | None = None) -> None:
        self.path = str(path)
        self.reason = " ".join(str(reason).split()) or "unreadable"
        self.recomputable = bool(recomputable)
        hint = advice or ("delete it and rerun to recompute it" if self.recomputable
                          else "check the file or give another one")
        super().__init__(f"{self.path} is damaged ({self.reason}); {hint}")


def damaged(path: str | PathLike, exc: BaseException, recomputable: bool = False) -> DamagedFileError:
    """Return a `DamagedFileError` for `path` whose reason is `exc` in one line.

    Use as ``raise damaged(path, exc, recomputable=True) from exc``.
    """
    text = str(exc).strip().splitlines()
    reason = f"{type(exc).__name__}: {text[0]}" if text and text[0] else type(exc).__name__
    return DamagedFileError(path, reason, recomputable=recomputable)
