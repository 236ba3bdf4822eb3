"""Each contact model against its independent reference, in one table of differences.

    python bench/verification.py [--json out.json]

Rows:

* ``FE / Hertz``: the axisymmetric FE without film against Hertz's radius (Table 1's cases and a small
  patch, R 250 mm / 15 kN);
* ``half-space / Hertz``: the wheel-rail model's half-space solver on a sphere without film (area-equivalent
  radius);
* ``half-space / thin-layer BEM``: the half-space with film springs against the axisymmetric ring BEM of the
  same spring film (a second formulation of the same model);
* ``half-space / FE`` per imprint model: the film as the wheel-rail corrector applies it (springs in series,
  read by `FilmModel.recorded_area_mm2`) against the film the calibration runs (the continuum FE, read by
  the same imprint model), sphere-on-flat at points off Table 1's grid: the transfer error that a wheel-rail
  answer inherits from calibration to application (sign: application minus calibration).

Figures are differences of radii in mm (and relative), measured in this run.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

#: (R mm, F kN, E MPa, nu) off Table 1's grid, across the calibrated range.
TRANSFER_POINTS = [(300.0, 35.0, 1200.0, 0.40), (375.0, 60.0, 2000.0, 0.33), (450.0, 75.0, 2800.0, 0.33),
                   (520.0, 40.0, 3500.0, 0.25), (600.0, 90.0, 6000.0, 0.33), (350.0, 50.0, 700.0, 0.30)]
HERTZ_CASES = [(250.0, 15.0), (300.0, 25.0), (300.0, 50.0), (450.0, 50.0), (450.0, 100.0), (600.0, 25.0),
               (600.0, 100.0)]


def _row(kind: str, case: str, value: float, reference: float) -> dict:
    return {"check": kind, "case": case, "value_mm": value, "reference_mm": reference,
            "difference_mm": value - reference, "relative": value / reference - 1.0}


def fe_against_hertz() -> list[dict]:
    from filmcal.fem import get_model

    rows = []
    for r, f in HERTZ_CASES:
        res = get_model(r).solve(None, f * 1e3)
        rows.append(_row("FE / Hertz", f"R{r:g} {f:g} kN", res.contact_radius_mm, res.hertz_radius_mm))
    return rows


def halfspace_against_hertz() -> list[dict]:
    from filmcal.hertz import hertz_radius_mm
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    rows = []
    for r, f in HERTZ_CASES[:3]:
        res = sphere_on_flat_contact(r, f * 1e3)
        rows.append(_row("half-space / Hertz", f"R{r:g} {f:g} kN", res.equivalent_radius_mm,
                         float(hertz_radius_mm(r, f * 1e3))))
    return rows


def halfspace_against_thin_layer() -> list[dict]:
    from filmcal.contact.laws import FilmLayer
    from filmcal.fem.thinlayer import thin_layer_contact
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    rows = []
    for r, f, e, nu in TRANSFER_POINTS[:3]:
        hs = sphere_on_flat_contact(r, f * 1e3, film=FilmLayer(e, nu, 0.09), spacing_mm=0.05)
        bem = thin_layer_contact(r, f * 1e3, e, nu, 0.09, ring_width_mm=0.01)
        rows.append(_row("half-space / thin-layer BEM", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}",
                         math.sqrt(hs.area_cells_mm2 / math.pi), bem.contact_radius_mm))
    return rows


def halfspace_against_fe() -> list[dict]:
    from filmcal.contact.film import FilmModel
    from filmcal.fem import Film, get_model
    from filmcal.films import FilmType
    from filmcal.wheelrail.edge import read_contact_edge
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    rows = []
    for r, f, e, nu in TRANSFER_POINTS:
        film = FilmType("HS-like", activation_pressure_mpa=50.0, range_mpa=(50.0, 130.0), poisson=nu)
        fe = get_model(r).solve(Film(e, nu), f * 1e3)
        for imprint in ("edge", "activation", "capsule"):
            model = FilmModel(film, imprint, "small")
            solver_film, solver_law, _ = model.interface(e)
            hs = sphere_on_flat_contact(r, f * 1e3, film=solver_film, law=solver_law)
            # the wheel-rail answer's readings: the edge as `WheelRailResult.area_mm2` reads it (the fitted
            # edge of wheelrail/edge.py), the other models through FilmModel on the pressure field
            area = read_contact_edge(hs).area_mm2 if imprint == "edge" else model.recorded_area_mm2(hs)
            hs_radius = math.sqrt(area / math.pi)
            fe_radius = fe.contact_radius_mm if imprint == "edge" else fe.read_imprint(imprint, film)
            rows.append(_row(f"half-space / FE, {imprint}", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}", hs_radius,
                             fe_radius))
            if imprint == "edge":  # where the pressure is positive, against the FE's edge
                rows.append(_row("half-space support / FE edge", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}",
                                 math.sqrt(hs.area_cells_mm2 / math.pi), fe_radius))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="FILE", help="also write the rows as JSON")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = fe_against_hertz() + halfspace_against_hertz() + halfspace_against_thin_layer() + halfspace_against_fe()
    print(f"{'check':34} {'case':30} {'value mm':>10} {'ref mm':>10} {'diff mm':>9} {'rel %':>8}")
    for row in rows:
        print(f"{row['check']:34} {row['case']:30} {row['value_mm']:10.4f} {row['reference_mm']:10.4f} "
              f"{row['difference_mm']:+9.4f} {100 * row['relative']:+8.3f}")
    for kind in sorted({r["check"] for r in rows}):
        d = np.array([r["difference_mm"] for r in rows if r["check"] == kind])
        print(f"summary {kind:34} mean {d.mean():+.4f} mm, range {d.min():+.4f} .. {d.max():+.4f} mm")
    print(f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
