"""The FE model's size and peak memory from its mesh settings, without building it.

`fe_sizes` counts the unknowns of `SphereOnFlat` from the mesh settings alone
(the graded node coordinates of `filmcal.fem.mesh`, no mesh, basis or matrix
is built: well under a millisecond). `fe_memory` turns them into the run's
peak resident memory, and `check_fe_memory` refuses, before any work, a mesh
that would not fit in the memory available now (`filmcal._memory`).

The model of the peak
---------------------
A solve has two phases; the peak is the larger (memory is returned between them):

1. condensing each steel body (`filmcal.fem.condense`): one sparse LU of the
   body's stiffness in nested-dissection order, whose fill grows slightly
   faster than the body's unknowns ``B`` (both bodies together):
   ``base + b (B / 2e5)^p``;
2. the film's solve: the bodies' condensed (dense) face matrices, and the film's
   dense stiffness parts (``K_lam``, ``K_mu``), the film's stiffness, the lower
   body's dense system and its Cholesky factor, all ``N_f x N_f`` with ``N_f =
   2 n (layers + 1)`` film unknowns (``n`` nodes on the contact face):
   ``base + c B + a N_f^2``, where ``a`` depends on what is solved (no film:
   only the film's parts are assembled; a large-strain film adds the dense
   tangent), plus ``24 (n_pairs - n) N_f`` for the extra tangential pair
   unknowns of friction or no-slip interfaces (the dense maps D and Y).

Fitted (least squares on log peak) to 75 measured peaks (peak RSS of ``filmcal fem`` in a subprocess, 0.2 to
12.1 GiB) over element sizes 0.02-0.1 mm, 1-8 film layers, sphere radii 60-100000 mm, without a film, with a
film and with a large-strain film: ``base = 78 MB``, ``b = 1.05 GB``, ``p = 1.145``, ``c = 1560 B``,
``a = 20.4 B`` (no film: the film's two dense parts and their assembly), ``51.4 B`` (small strain),
``77.5 B`` (large strain: the dense tangent). Estimated/measured lie within 0.83-1.21 (rms 5 %); the
friction term (``24 B``) is the size of the dense maps, checked at one point (0.05 mm, 8 layers: +39 MiB
measured, +33 MB estimated). ``python bench/memory.py`` repeats the comparison at the largest settings this
machine allows.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from filmcal._memory import MemoryEstimate, check_memory
from filmcal.fem.mesh import FILM_LAYERS, MeshSettings, _radial_and_depth, default_contact_zone_mm

__all__ = ["FESizes", "fe_sizes", "fe_memory", "check_fe_memory", "FE_MEMORY_MODEL"]

#: The fitted coefficients of the peak-memory model (module notes), bytes.
FE_MEMORY_MODEL = {
    "base": 78e6,
    "body_lu": 1.05e9, "body_lu_exponent": 1.145,  # at 2e5 body unknowns (both bodies)
    "body_retained": 1560.0,  # per body unknown, during the film's solve
    "film": {"none": 20.4, "small": 51.4, "large": 77.5},  # per film unknown squared
    "pairs": 24.0,  # per extra tangential pair unknown and film unknown
}


@dataclass(frozen=True)
class FESizes:
    """The unknowns of one `SphereOnFlat`.

    Attributes
    ----------
    face_nodes : int
        Nodes on the contact face in the refined zone (``n``).
    body_unknowns : int
        Displacement unknowns of both steel bodies together (``B``).
    film_unknowns : int
        Displacement unknowns of the film (``N_f = 2 n (layers + 1)``).
    """

    face_nodes: int
    body_unknowns: int
    film_unknowns: int


def fe_sizes(sphere_radius_mm: float, mesh: MeshSettings | None = None, film_layers: int = FILM_LAYERS) -> FESizes:
    """Count the FE model's unknowns from its settings (the grids' coordinates only)."""
    mesh = MeshSettings() if mesh is None else mesh
    zone = default_contact_zone_mm(float(sphere_radius_mm), mesh)
    r, depth = _radial_and_depth(zone, mesh)
    n = int(np.searchsorted(r, zone + 1e-9))
    return FESizes(n, 2 * 2 * len(r) * len(depth), 2 * n * (int(film_layers) + 1))


def fe_memory(sphere_radius_mm: float, mesh: MeshSettings | None = None, film_layers: int = FILM_LAYERS,
              film: bool = True, kinematics: str = "small", sphere_contact: str = "frictionless",
              flat_contact: str = "tied") -> MemoryEstimate:
    """The estimated peak memory of building and solving one FE model (module notes: the model, its fit)."""
    s = fe_sizes(sphere_radius_mm, mesh, film_layers)
    k = FE_MEMORY_MODEL
    kind = "none" if not film else ("large" if kinematics == "large" else "small")
    extra_pairs = s.face_nodes * ((sphere_contact != "frictionless") + (film and flat_contact == "friction"))
    bodies = k["base"] + k["body_lu"] * (s.body_unknowns / 2e5) ** k["body_lu_exponent"]
    solve = (k["base"] + k["body_retained"] * s.body_unknowns + k["film"][kind] * s.film_unknowns ** 2
             + k["pairs"] * extra_pairs * s.film_unknowns)
    what = (f"FE: {s.film_unknowns} film unknowns in dense matrices, {s.body_unknowns} body unknowns factorised"
            if solve >= bodies else
            f"FE: {s.body_unknowns} body unknowns factorised, {s.film_unknowns} film unknowns")
    return MemoryEstimate(max(bodies, solve), what,
                          "max(base + b (B/2e5)^p, base + c B + a N_f^2 + 24 extra_pairs N_f) "
                          "(filmcal.fem.memory)")


def check_fe_memory(sphere_radius_mm: float, mesh: MeshSettings | None = None, film_layers: int = FILM_LAYERS,
                    film: bool = True, kinematics: str = "small", sphere_contact: str = "frictionless",
                    flat_contact: str = "tied", options: str | None = None) -> MemoryEstimate:
    """Refuse, before any work, an FE model whose estimated peak exceeds the memory a run may use now.

    Parameters
    ----------
    options : str, optional
        The options that set the size as the user gave them, for the message (default: the parameters'
        names and values).

    Raises
    ------
    filmcal._errors.InputError
        One line naming the sizes, the estimate, the available memory and what to change.
    """
    mesh = MeshSettings() if mesh is None else mesh
    estimate = fe_memory(sphere_radius_mm, mesh, film_layers, film, kinematics, sphere_contact, flat_contact)
    if options is None:
        options = (f"element_size_mm {mesh.element_size_mm:g} with film_layers {int(film_layers)} and "
                   f"sphere_radius_mm {float(sphere_radius_mm):g}")
    advice = "use a coarser mesh (a larger element size)" + (" or fewer film layers" if film else "")
    return check_memory(estimate, options, advice)


#: A campaign's worker process after its first FE point at the paper's mesh (imports, one model, one solve),
#: and what each further point adds until the worker's heap levels off near `filmcal._memory.WORKER_BYTES`
#: (glibc keeps freed heap in workers, `filmcal._parallel.keep_freed_memory`; the FE model cache keeps 8
#: models). Measured: 201 MiB after one point, +15-30 MiB per point of a new radius, 448-526 MiB after 12.
FE_WORKER_FIRST_BYTES = 200 * 2**20
FE_WORKER_PER_TASK_BYTES = 25 * 2**20


def fe_worker_memory(tasks: int, largest: MemoryEstimate, sizes: FESizes, models: int) -> float:
    """Peak memory of one worker process that runs `tasks` FE points (bytes).

    ``min(plateau, first + per_task (tasks - 1))`` at the paper's mesh (`FE_WORKER_FIRST_BYTES`,
    `FE_WORKER_PER_TASK_BYTES`, the plateau `filmcal._memory.WORKER_BYTES`), or for finer meshes the largest
    point's estimate plus the models the worker keeps (at most 7 more of `models` distinct ones), each its
    bodies' condensed matrices and the film's dense parts: ``12 MB + 32 (2 n)^2 + 16 N_f^2`` bytes (`sizes`
    of the largest point).
    """
    from filmcal._memory import worker_memory

    tasks = max(1, int(tasks))
    plateau = worker_memory("campaign")[0]
    paper = min(plateau, FE_WORKER_FIRST_BYTES + FE_WORKER_PER_TASK_BYTES * (tasks - 1))
    kept = 12e6 + 32.0 * (2 * sizes.face_nodes) ** 2 + 16.0 * sizes.film_unknowns ** 2
    fine = largest.bytes + min(7, max(0, min(tasks, models) - 1)) * kept
    return max(paper, fine)
