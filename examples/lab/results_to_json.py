"""The lab's glue: parse the solver's text results file and print the JSON object filmcal reads.

filmcal needs ``contact_radius_mm``; with the pressure profile (``radius_mm``, ``pressure_mpa``) it reads
every imprint model of every film itself.

Usage: python results_to_json.py results.txt
"""
from __future__ import annotations

import json
import sys


def parse(path: str) -> dict:
    radius, r, p, table = None, [], [], False
    for line in open(path, encoding="utf-8"):
        text = line.strip()
        if text.startswith("CONTACT RADIUS (MM)"):
            radius = float(text.split("=")[1])
        elif text.startswith("R (MM)"):
            table = True
        elif text == "END":
            table = False
        elif table and text:
            a, b = text.split()
            r.append(float(a))
            p.append(float(b))
    if radius is None:
        raise SystemExit(f"{path}: no CONTACT RADIUS line")
    return {"contact_radius_mm": radius, "radius_mm": r, "pressure_mpa": p}


if __name__ == "__main__":
    print(json.dumps(parse(sys.argv[1])))
