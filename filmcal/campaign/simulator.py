"""Where a study's sphere-on-flat runs come from: the in-house FE, or a lab's own simulator.

A lab with an FE deck of its own film model (the paper's set-up was Abaqus) calibrates it here by naming it:

* ``Simulator(python="MODULE:FUNCTION")``: a function called with a dict of `SIMULATOR_INPUTS`
  (``modulus_mpa``, ``poisson``, ``sphere_radius_mm``, ``force_kn``, ``film_thickness_mm``) that returns a
  dict;
* ``Simulator(umbridge="http://host:port", umbridge_model="NAME")``: a UM-Bridge model (protocol 1.0, any
  language) whose one input vector is `SIMULATOR_INPUTS` in that order and whose output vectors are
  ``[contact_radius_mm]`` and optionally ``radius_mm`` and ``pressure_mpa``;
* ``Simulator(command="TEMPLATE")``: a shell command run once per point in a fresh folder, with the
  conventions of ``filmcal campaign run --simulator-command`` (`filmcal.campaign.command.CommandModel`):
  placeholders ``{modulus_mpa}``, ``{poisson}``, ``{sphere_radius_mm}``, ``{force_kn}``,
  ``{film_thickness_mm}``, ``{work_dir}`` and ``{point_id}``, input files rendered from templates, a JSON
  object on stdout or in ``outputs.json``, a timeout, a failure recorded with its reason.

Either returns ``contact_radius_mm`` (the edge of the contact, the ``edge`` imprint model's reading) and
optionally the film's pressure profile over the radius as two lists, ``radius_mm`` and ``pressure_mpa``:
then filmcal reads every other imprint model (``activation``, ``capsule``) of every film itself, exactly as
it reads its own FE's profile. A point whose answer has no finite positive ``contact_radius_mm`` is a
failed run with that reason; the campaign store keeps every run, so a killed calibration resumes without
running a point twice.
"""
from __future__ import annotations

import importlib
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from filmcal._errors import InputError
from filmcal.campaign.command import CommandModel, ModelFailure

__all__ = ["Simulator", "SimulatorModel", "SIMULATOR_INPUTS", "PROFILE_OUTPUTS", "import_model"]

#: What a simulator is given, in the vocabulary's names.
SIMULATOR_INPUTS = ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn", "film_thickness_mm")
#: The optional pressure profile a simulator may return beside ``contact_radius_mm``.
PROFILE_OUTPUTS = ("radius_mm", "pressure_mpa")
_MODEL_SPEC = re.compile(r"^[A-Za-z_][\w.]*:[A-Za-z_]\w*$")


def import_model(spec: str) -> Callable[[dict], dict]:
    """Import the model ``module:function`` by name (nothing is read from data files)."""
    if not isinstance(spec, str) or not _MODEL_SPEC.match(spec):
        raise InputError(f"--simulator-python must be given as MODULE:FUNCTION, got {spec!r}")
    module_name, function_name = spec.split(":")
    try:
        model = getattr(importlib.import_module(module_name), function_name)
    except (ImportError, AttributeError) as exc:
        raise InputError(f"cannot import the model {spec}: {exc}") from None
    if not callable(model):
        raise InputError(f"model {spec} is not callable")
    return model


@dataclass(frozen=True)
class Simulator:
    """A lab's simulator of sphere-on-flat with film (module notes): exactly one of `python` and `command`.

    Parameters
    ----------
    python : str, optional
        ``MODULE:FUNCTION``.
    command : str, optional
        A command template.
    template_files : tuple of (name, text)
        Input files rendered into each point's folder (a command only).
    timeout_s : float, optional
        Deadline of one run (a command only).
    """

    python: str | None = None
    command: str | None = None
    template_files: tuple[tuple[str, str], ...] = field(default=(), repr=False)
    timeout_s: float | None = None
    umbridge: str | None = None
    umbridge_model: str | None = None

    def __post_init__(self) -> None:
        given = [x is not None for x in (self.python, self.command, self.umbridge)]
        if sum(given) != 1:
            raise InputError("give the simulator as one of a Python function, a command or a UM-Bridge model")
        if self.umbridge is not None:
            if not re.match(r"^https?://[^\s/]+(/[^\s]*)?$", self.umbridge):
                raise InputError(f"--simulator-umbridge must be an http(s) URL, got {self.umbridge!r}")
            if not self.umbridge_model:
                raise InputError("--simulator-umbridge needs --umbridge-model NAME")
            if self.template_files:
                raise InputError("template files belong to a command simulator")
            return
        if self.umbridge_model is not None:
            raise InputError("--umbridge-model needs --simulator-umbridge URL")
        if self.python is not None:
            import_model(self.python)  # an unimportable model is refused before any work
            if self.template_files or self.timeout_s is not None:
                raise InputError("template files and a timeout belong to a command simulator")
        else:
            placeholders = CommandModel(self.command, Path("."), self.template_files, self.timeout_s).placeholders
            missing = [name for name in placeholders if name not in SIMULATOR_INPUTS]
            if missing:
                raise InputError(f"--simulator-command: placeholder(s) {', '.join('{' + m + '}' for m in missing)} "
                                 f"are not inputs of a run; use {', '.join('{' + n + '}' for n in SIMULATOR_INPUTS)}, "
                                 "{work_dir} and {point_id}")
            if not set(placeholders) & set(SIMULATOR_INPUTS[:4]):  # the inputs a design varies
                raise InputError(f"--simulator-command {self.command!r} and its template files use none of "
                                 f"{', '.join('{' + n + '}' for n in SIMULATOR_INPUTS[:4])}: every run would "
                                 "be the same run; pass the inputs to the simulator")

    def spec(self) -> dict[str, Any]:
        """What makes its runs: the runs of equal specs are the same runs."""
        if self.python is not None:
            return {"python": self.python}
        if self.umbridge is not None:
            return {"umbridge": self.umbridge.rstrip("/"), "model": self.umbridge_model}
        model = CommandModel(self.command, Path("."), self.template_files, self.timeout_s)
        return {"command": self.command, **model.settings(), "timeout_s": self.timeout_s}

    def label(self) -> str:
        if self.umbridge is not None:
            return f"UM-Bridge model {self.umbridge_model!r} at {self.umbridge}"
        return f"python {self.python}" if self.python is not None else f"command {self.command!r}"

    def model(self, pairs: Sequence[tuple[str, Any]], work_root: str | Path) -> "SimulatorModel":
        """The campaign model of this simulator, reading the (imprint model, film) `pairs` from its profiles."""
        return SimulatorModel(self, tuple(pairs), Path(work_root))


@dataclass(frozen=True)
class SimulatorModel:
    """One run of a `Simulator`: its inputs in, ``contact_radius_mm`` and the imprint readings out."""

    simulator: Simulator
    pairs: tuple[tuple[str, Any], ...]
    work_root: Path
    takes_point_id: ClassVar[bool] = True

    @property
    def model_name(self) -> str:
        return self.simulator.label()

    def __call__(self, params: Mapping[str, Any], point_id: str | None = None) -> dict[str, Any]:
        inputs = {name: float(params[name]) for name in SIMULATOR_INPUTS}
        sim = self.simulator
        if sim.python is not None:
            raw = import_model(sim.python)(dict(inputs))
            if not isinstance(raw, Mapping):
                raise ModelFailure(f"{sim.python} returned a {type(raw).__name__}, not a dict")
        elif sim.umbridge is not None:
            raw = _umbridge_evaluate(sim, [inputs[name] for name in SIMULATOR_INPUTS])
        else:
            command = CommandModel(sim.command, self.work_root, sim.template_files, sim.timeout_s,
                                   arrays=PROFILE_OUTPUTS)
            raw = command(inputs, point_id=point_id)
        radius = raw.get("contact_radius_mm")
        if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not (math.isfinite(radius)
                                                                                   and radius > 0):
            reason = raw.get("reason") if isinstance(raw.get("reason"), str) else None
            raise ModelFailure(reason or f"no finite contact_radius_mm > 0 in the answer (got {radius!r})")
        out: dict[str, Any] = {"contact_radius_mm": float(radius), "converged": True}
        if self.pairs and all(name in raw for name in PROFILE_OUTPUTS):
            import numpy as np

            from filmcal.contact.imprint import read_imprints

            r, p = (np.asarray(raw[name], dtype=float) for name in PROFILE_OUTPUTS)
            if r.ndim != 1 or r.shape != p.shape or r.size < 3 or not (np.all(np.isfinite(r))
                                                                       and np.all(np.isfinite(p))):
                raise ModelFailure("radius_mm and pressure_mpa must be two lists of equal length (>= 3) of "
                                   "finite numbers")
            try:
                out.update(read_imprints(r, p, self.pairs))
            except ValueError as exc:
                raise ModelFailure(f"the pressure profile cannot be read: {exc}") from None
        return out


def _umbridge_evaluate(sim: Simulator, vector: list[float]) -> dict[str, Any]:
    """One UM-Bridge Evaluate (protocol 1.0): the outputs by name, or a `ModelFailure` saying why not."""
    import json
    import urllib.error
    import urllib.request

    body = json.dumps({"name": sim.umbridge_model, "input": [vector], "config": {}}).encode()
    request = urllib.request.Request(sim.umbridge.rstrip("/") + "/Evaluate", data=body, method="POST",
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=sim.timeout_s or 3600.0) as response:
            answer = json.loads(response.read())
    except urllib.error.HTTPError as exc:
        try:
            error = json.loads(exc.read()).get("error", {})
            text = f"{error.get('type', 'error')}: {error.get('message', '')}"
        except ValueError:
            text = f"HTTP {exc.code}"
        raise ModelFailure(f"the UM-Bridge model answered {text}") from None
    except (urllib.error.URLError, OSError, ValueError) as exc:
        raise ModelFailure(f"the UM-Bridge server at {sim.umbridge} cannot be reached or answered no JSON "
                           f"({exc})") from None
    output = answer.get("output") if isinstance(answer, dict) else None
    if not (isinstance(output, list) and output and all(isinstance(v, list) for v in output) and output[0]):
        raise ModelFailure(f"the UM-Bridge answer has no output vectors (got {str(answer)[:200]})")
    raw: dict[str, Any] = {"contact_radius_mm": output[0][0]}
    if len(output) >= 3:
        raw.update(radius_mm=output[1], pressure_mpa=output[2])
    return raw
