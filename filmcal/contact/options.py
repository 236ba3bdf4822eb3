"""The FE model's interface and kinematics options: one dataclass, its defaults and its column form written once.

Light on purpose (no FE imports): the command line builds its options from these
defaults, campaigns store them as design columns, studies as spec fields.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Mapping

from filmcal._validation import as_bool, as_finite, check_choice, check_range
from filmcal.contact.names import DEFAULT_KINEMATICS, KINEMATICS

__all__ = ["ContactOptions", "CONTACT_MODES", "COLUMNS"]

#: Tangential behaviour of an interface.
CONTACT_MODES = ("frictionless", "tied", "friction")
#: The options a campaign design carries as columns.
COLUMNS = ("sphere_contact", "flat_contact", "friction_coefficient", "kinematics")


@dataclass(frozen=True)
class ContactOptions:
    """Interface and kinematics options of an evaluation.

    Parameters
    ----------
    sphere_contact, flat_contact : {'frictionless', 'tied', 'friction'}
        Tangential behaviour at the sphere-film and film-flat interfaces.
    friction_coefficient : float
        Coulomb coefficient for 'friction' interfaces (the paper: 0.4).
    kinematics : {'small', 'large'}
        'large': a geometrically nonlinear film (compressible neo-Hookean,
        total Lagrangian) instead of small-strain linear elasticity.
    load_steps : int or None
        Load increments; None picks 1 for the path-independent linear cases,
        4 for a large-strain film with frictionless/tied interfaces, and 32 for
        friction or no-slip at the sphere (the loading path matters there, and
        fewer increments leave stick-slip noise in the edge pressures).
    max_iterations : int
        Limit of active-set (and Newton) iterations per load step.
    """

    sphere_contact: str = "frictionless"
    flat_contact: str = "tied"
    friction_coefficient: float = 0.4
    kinematics: str = DEFAULT_KINEMATICS
    load_steps: int | None = None
    max_iterations: int = 60

    def __post_init__(self) -> None:
        check_choice("sphere_contact", self.sphere_contact, CONTACT_MODES)
        check_choice("flat_contact", self.flat_contact, CONTACT_MODES)
        check_range("friction_coefficient", self.friction_coefficient, 0.0, 10.0, low_open=False)
        check_choice("kinematics", self.kinematics, KINEMATICS)
        if self.load_steps is not None and (int(self.load_steps) != self.load_steps or self.load_steps < 1):
            raise ValueError(f"load_steps must be an integer >= 1, got {self.load_steps!r}")
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise ValueError(f"max_iterations must be an integer >= 1, got {self.max_iterations!r}")

    @property
    def large_strain(self) -> bool:
        """Whether the film is the large-strain (neo-Hookean) film."""
        return self.kinematics == "large"

    @property
    def path_dependent(self) -> bool:
        return self.sphere_contact != "frictionless" or self.flat_contact == "friction"

    def steps(self) -> int:
        if self.load_steps is not None:
            return int(self.load_steps)
        if self.path_dependent:
            return 32
        return 4 if self.large_strain else 1

    def as_columns(self) -> dict:
        """The options as a campaign design's columns (the inverse of `from_columns`)."""
        return {"sphere_contact": self.sphere_contact, "flat_contact": self.flat_contact,
                "friction_coefficient": self.friction_coefficient, "kinematics": self.kinematics}

    @classmethod
    def from_columns(cls, columns: Mapping[str, Any]) -> "ContactOptions":
        """Options from a design point's columns; a missing or empty column takes the default.

        Raises
        ------
        ValueError
            Naming the column, for a value out of its choices or range.
        """
        def get(name: str):
            value = columns.get(name)
            return None if value is None or (isinstance(value, str) and value.strip() == "") else value

        values: dict[str, Any] = {}
        if get("kinematics") is None and get("large_strain") is not None:  # a store of an earlier release
            values["kinematics"] = "large" if as_bool("large_strain", get("large_strain")) else "small"
        for f in fields(cls):
            raw = get(f.name)
            if raw is None or f.name not in COLUMNS:
                continue
            if f.name in ("sphere_contact", "flat_contact"):
                values[f.name] = check_choice(f.name, str(raw), CONTACT_MODES)
            elif f.name == "kinematics":
                values[f.name] = check_choice(f.name, str(raw), KINEMATICS)
            elif f.name == "friction_coefficient":
                values[f.name] = as_finite(f.name, raw)
            else:
                values[f.name] = as_bool(f.name, raw)
        return cls(**values)

