"""Film types: the built-in Prescale grades and a lab's own films.

A film type is what the models need to know about a film besides its
modulus: the pressure range it measures (its lower end is the *activation
pressure*, above which the microcapsules break and the film colours), the
thickness of its carrier and a nominal Poisson's ratio. The built-in types are
the reference paper's (section 1): MS 10-50, HS 50-130 and HHS 130-300 MPa on a
90 um PET carrier, nu = 0.33.

A lab adds its own types (another grade, a lot, another make) in a small TOML
file, one table per film::

    [LOT7]
    activation_pressure_mpa = 45      # or: range_mpa = [45, 120]
    thickness_mm = 0.1                # optional, default 0.09
    poisson = 0.34                    # optional, default 0.33
    description = "HS, lot 7, 2026"   # optional

A film without an activation pressure (and no range) is read with the ``edge``
imprint model only. Loading a TOML file never executes code from it.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Mapping

__all__ = ["FilmType", "FilmRegistry", "BUILTIN_FILMS", "FILM_TYPES", "ACTIVATION_PRESSURE_MPA",
           "FILM_THICKNESS_MM", "FILM_POISSON", "get_film", "load_films_file"]

#: Thickness of the films' PET carrier, as modelled in the paper (mm).
FILM_THICKNESS_MM = 0.09
#: Nominal Poisson's ratio of the film (the paper's value).
FILM_POISSON = 0.33


#: The highest pressure a film type may name (MPa): a margin over the Prescale range (HHS: 130-300 MPa), so
#: that a unit error (kPa, Pa) is refused rather than read as a film that never colours.
MAX_FILM_PRESSURE_MPA = 1000.0


@dataclass(frozen=True)
class FilmType:
    """One film type.

    Parameters
    ----------
    name : str
        Its name as used in datasets and on the command line (``HS``, ``LOT7``).
    activation_pressure_mpa : float or None
        Pressure above which the film colours (MPa); None when unknown (the
        film is then read with the ``edge`` imprint model only).
    range_mpa : (float, float) or None
        Measurement range (MPa); its lower end is the activation pressure when
        that is not given.
    thickness_mm : float
        Thickness of the film (mm), > 0.
    poisson : float
        Nominal Poisson's ratio, -1 < nu < 0.5.
    description : str
        Free text.
    """

    name: str
    activation_pressure_mpa: float | None = None
    range_mpa: tuple[float, float] | None = None
    thickness_mm: float = FILM_THICKNESS_MM
    poisson: float = FILM_POISSON
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name or self.name != self.name.strip() \
                or any(c in self.name for c in "/\\\0") or len(self.name) > 64:
            raise ValueError(f"film name must be 1-64 characters without surrounding spaces or "
                             f"slashes, got {self.name!r}")
        if self.range_mpa is not None:
            lo, hi = (float(v) for v in self.range_mpa)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi <= MAX_FILM_PRESSURE_MPA):
                raise ValueError(f"film {self.name}: range_mpa must be two finite pressures 0 < lo < hi <= "
                                 f"{MAX_FILM_PRESSURE_MPA:g}, "
                                 f"got {list(self.range_mpa)}")
            object.__setattr__(self, "range_mpa", (lo, hi))
            if self.activation_pressure_mpa is None:
                object.__setattr__(self, "activation_pressure_mpa", lo)
        if self.activation_pressure_mpa is not None:
            act = float(self.activation_pressure_mpa)
            if not (math.isfinite(act) and 0 < act <= MAX_FILM_PRESSURE_MPA):
                raise ValueError(f"film {self.name}: activation_pressure_mpa must be in (0, {MAX_FILM_PRESSURE_MPA:g}] "
                                 f"MPa (Prescale films colour between a few kPa and 300 MPa), got {act:g}")
            if self.range_mpa is not None and not self.range_mpa[0] <= act <= self.range_mpa[1]:
                raise ValueError(f"film {self.name}: activation_pressure_mpa {act:g} lies outside its range_mpa "
                                 f"{list(self.range_mpa)}: a film starts colouring within its range")
            object.__setattr__(self, "activation_pressure_mpa", act)
        t = float(self.thickness_mm)
        if not (math.isfinite(t) and 0 < t <= 5):
            raise ValueError(f"film {self.name}: thickness_mm must be in (0, 5] mm, got {t}")
        object.__setattr__(self, "thickness_mm", t)
        nu = float(self.poisson)
        if not (math.isfinite(nu) and -1 < nu < 0.5):
            raise ValueError(f"film {self.name}: poisson must be in (-1, 0.5), got {nu}")
        object.__setattr__(self, "poisson", nu)

    @property
    def has_activation(self) -> bool:
        """Whether the film's activation pressure is known."""
        return self.activation_pressure_mpa is not None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (the form recorded in a study's manifest)."""
        d = asdict(self)
        d["range_mpa"] = None if self.range_mpa is None else list(self.range_mpa)
        return d

    @classmethod
    def from_dict(cls, name: str, data: Mapping[str, Any]) -> "FilmType":
        """A film from a TOML table or a manifest entry (unknown keys are refused)."""
        allowed = {"activation_pressure_mpa", "range_mpa", "thickness_mm", "poisson", "description", "name"}
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise ValueError(f"film {name}: unknown key(s) {', '.join(unknown)}; allowed: "
                             f"{', '.join(sorted(allowed - {'name'}))}")
        kw = {k: v for k, v in data.items() if k != "name"}
        if "range_mpa" in kw and kw["range_mpa"] is not None:
            rng = kw["range_mpa"]
            if not isinstance(rng, (list, tuple)) or len(rng) != 2:
                raise ValueError(f"film {name}: range_mpa must be a list of two pressures, got {rng!r}")
            kw["range_mpa"] = tuple(rng)
        for key in ("activation_pressure_mpa", "thickness_mm", "poisson"):
            if key in kw and kw[key] is not None and (isinstance(kw[key], bool)
                                                      or not isinstance(kw[key], (int, float))):
                raise ValueError(f"film {name}: {key} must be a number, got {kw[key]!r}")
        if "description" in kw and not isinstance(kw["description"], str):
            raise ValueError(f"film {name}: description must be text")
        return cls(name=name, **kw)


#: The reference paper's film types, from the softest to the stiffest range.
BUILTIN_FILMS: dict[str, FilmType] = {
    "MS": FilmType("MS", range_mpa=(10.0, 50.0), description="Prescale MS (medium pressure)"),
    "HS": FilmType("HS", range_mpa=(50.0, 130.0), description="Prescale HS (high pressure)"),
    "HHS": FilmType("HHS", range_mpa=(130.0, 300.0), description="Prescale HHS (super high pressure)"),
}
#: Film types of Table 1, from the softest to the stiffest measurement range.
FILM_TYPES: tuple[str, ...] = tuple(BUILTIN_FILMS)
#: Lower ends of the measurement ranges: the pressure above which a film type colours.
ACTIVATION_PRESSURE_MPA: dict[str, float] = {k: f.activation_pressure_mpa for k, f in BUILTIN_FILMS.items()}


class FilmRegistry:
    """The film types known to a run: the built-in ones plus user films.

    Parameters
    ----------
    films : mapping of name to FilmType, optional
        User films; a user film may not redefine a built-in name differently.
    """

    def __init__(self, films: Mapping[str, FilmType] | None = None) -> None:
        self._films: dict[str, FilmType] = dict(BUILTIN_FILMS)
        for name, film in (films or {}).items():
            if name in BUILTIN_FILMS and BUILTIN_FILMS[name] != film:
                raise ValueError(f"film {name} is built in; give your film another name")
            self._films[name] = film

    @classmethod
    def from_file(cls, path: str | Path | None) -> "FilmRegistry":
        """Built-in films plus those of a TOML file (None: built-in only)."""
        return cls(None if path is None else load_films_file(path))

    def __contains__(self, name: object) -> bool:
        return name in self._films

    def __iter__(self):
        return iter(self._films)

    def names(self) -> tuple[str, ...]:
        return tuple(self._films)

    def get(self, name: str) -> FilmType:
        """The film type called `name`; a clear `ValueError` when unknown."""
        if name in self._films:
            return self._films[name]
        hint = ""
        if isinstance(name, str) and name.strip() in self._films:
            hint = f" (remove the surrounding spaces: {name.strip()!r})"
        raise ValueError(f"unknown film {name!r}{hint}; known: {', '.join(self._films)} "
                         "(add your own with --films-file)")


def load_films_file(path: str | Path) -> dict[str, FilmType]:
    """Read user film types from a TOML file (one table per film).

    Raises
    ------
    ValueError
        The file is missing, not valid TOML, or a film is malformed; the
        message names the file.
    """
    path = Path(path)
    try:
        with path.open("rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ValueError(f"films file {path}: not found") from None
    except IsADirectoryError:
        raise ValueError(f"films file {path}: is a folder, give a TOML file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"films file {path}: not valid TOML ({exc})") from None
    films = {}
    for name, table in data.items():
        if not isinstance(table, dict):
            raise ValueError(f"films file {path}: {name!r} must be a table ([{name}])")
        if table and all(isinstance(v, dict) for v in table.values()):  # [films.LOT7]: a level too deep
            raise ValueError(f"films file {path}: [{name}] holds tables ({', '.join(table)}); each film is a table "
                             f"of its own at the top: [{next(iter(table))}], not [{name}.{next(iter(table))}]")
        try:
            films[name] = FilmType.from_dict(name, table)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"films file {path}: {exc}") from None
    if not films:
        raise ValueError(f"films file {path}: defines no film")
    return films


def get_film(name: str, films_file: str | Path | None = None) -> FilmType:
    """The film type `name`, built in or from `films_file`."""
    return FilmRegistry.from_file(films_file).get(name)
