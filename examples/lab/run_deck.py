"""Stand-in for a lab's commercial FE solver: reads an input deck, writes a text results file.

A lab replaces this with its own solver call (for example ``abaqus job=deck input=deck.inp``). Here the
solve is filmcal's own axisymmetric FE, so that the example runs anywhere; nothing else in the workflow
knows that.

Usage: python run_deck.py deck.inp results.txt
"""
from __future__ import annotations

import sys


def read_deck(path: str) -> dict[str, float]:
    values = {}
    for line in open(path, encoding="utf-8"):
        line = line.strip()
        if line and not line.startswith("**"):
            key, value = (part.strip() for part in line.split("=", 1))
            values[key] = float(value)
    return values


def main(deck: str, results: str) -> int:
    from filmcal.fem import Film, solve_sphere_on_flat

    d = read_deck(deck)
    res = solve_sphere_on_flat(d["SPHERE_RADIUS_MM"], 1e3 * d["FORCE_KN"],
                               Film(d["FILM_MODULUS_MPA"], d["FILM_POISSON"]),
                               film_thickness_mm=d["FILM_THICKNESS_MM"])
    if not res.converged:
        print("*** ERROR: the contact iteration did not converge", file=sys.stderr)
        return 2
    with open(results, "w", encoding="utf-8") as fh:
        fh.write("** STAND-IN FE RESULTS\n")
        fh.write(f"CONTACT RADIUS (MM) = {res.contact_radius_mm:.6f}\n")
        fh.write("NODAL CONTACT PRESSURE\n    R (MM)      P (MPA)\n")
        for r, p in zip(res.r_mm, res.pressure_mpa):
            fh.write(f"{r:10.5f} {p:12.5f}\n")
        fh.write("END\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(*sys.argv[1:3]))
