"""Independent CONTACT reference numbers for filmcal's wheel-rail model: decks, runs, parsing, JSON.

What it does
------------
For a small built-in case list (``--set flange`` or ``--set layer``) this script

1. writes the wheel and rail profile files CONTACT reads (sampled by ``filmcal profile NAME --step-mm
   0.05``, converted to CONTACT's canonical form, see below),
2. writes one CONTACT input deck (``.inp``, module 1, wheel-rail) per case and grid,
3. with ``--contact PATH`` runs CONTACT on each deck (one process at a time, ``OMP_NUM_THREADS=1``,
   in a scratch directory so that no bulky output lands next to the decks), parses its ``.out`` and
   ``.mat`` files, and
4. writes a JSON with, per case and grid, the contact area (number of elements in contact times the
   element area DX*DS), the max pressure, the normal force, the contact angle and contact reference
   point (track, rail and wheel coordinates), the approach (CONTACT's PEN, normal to the contact plane),
   the pressure centroid, and per case a Richardson extrapolation over the grid sequence (observed
   order from three grids, each grid halving DX and DS).

The numbers come from CONTACT only; filmcal is used for nothing but sampling the standard profiles.

Geometry mapping (filmcal -> CONTACT)
-------------------------------------
filmcal (``filmcal.wheelrail.placement``): track frame with y towards the field side and z upwards,
origin at the rail crown top (the rail profile's origin), rail rotated about that origin by
atan(inclination) with its axis leaning to the gauge side; the wheel (horizontal axle, tape circle at
wheel y = 0, nominal radius 460 mm at the tape circle) shifted laterally by eta, i.e. a track point y is
wheel point y - eta; eta > 0 moves the flange towards the gauge corner; the wheel moves vertically only.

CONTACT (user guide, "single wheel-rail configuration"): right wheel on right rail (CONFIG C1=1,
y positive to the field side for both profiles, z positive downwards),

* absolute rail placement: GAUGHT = -1 (gauge computation off), RAILY0 = RAILZ0 = 0 (rail origin at the
  track origin), CANT = atan(inclination) (positive = inclined towards the track centre; applied to the
  right rail as a rotation about its origin, as filmcal does);
* the wheel-profile origin under the wheelset centre: FBDIST = 2 FBPOS (FBPOS = -70, FBDIST = -140, so
  that d_flng/2 - y_fbpos = 0), NOMRADW = nominal radius, YTAPE = 0 (the S1002 datum z(0) = 0 already);
* Y_WS = eta (the wheel-profile origin at track y = eta), ROLL = YAW = PITCH = 0, vertical force
  FZ_WS = F prescribed (N digit 1): CONTACT lowers the wheelset vertically until the vertical force is F.
* profiles: rail z_contact = -z_filmcal (filmcal's rail z points up), wheel z_contact = +z_filmcal
  (filmcal's wheel z points radially outwards = down at the contact), y unchanged, MIRRORY = 0,
  MIRRORZ = -1 (use as given), no smoothing; rail points in ascending y, wheel points in descending y
  (CONTACT's canonical order), written as plain two-column text (a ``.txt`` extension means "plain y z").

Contact angle and reference point (output, sign and definition): CONTACT's DELTTR is the rotation from
the track z axis to the contact normal, negative on a right wheel; the script reports
``contact_angle_deg = -DELTTR`` in degrees (DELT_CP(R) of the .mat file minus the rail roll, 6 digits).
With DISCNS D=2 (planar contact, "wgt-wgt-2") CONTACT places the contact reference at the
interpenetration-weighted centre of the rigid overlap and uses the overlap-weighted mean surface
inclination as the contact angle (m_wr_locatecp.f90: compute_wgt_center_1d, set_cpatch_reference);
filmcal's plane is the tangent at the first contact point. YCP(R), YCP(W) are in the rail's and the
wheel's own profile coordinates (= filmcal's standard y). The pressure centroid is computed here from the
element pressures of the .mat file (local s, mapped onto the rail by y_r = YCP(R) + s cos(DELT_CP(R))).

Kinematics: CONTACT lowers the wheelset vertically (N=1) and builds the gap from the overlapping
profiles at the final position; so does filmcal, in the tangent plane of the first-touch geometry, with
the slide along that plane that the vertical approach brings. On a flange (theta ~ 70 deg) a vertical
approach dz = delta/cos theta contains a slide dz sin(theta) (~0.14 mm at eta 5) of the wheel along the
rail, which changes the result where the patch straddles a profile joint (eta 5: S1002 straight face /
R20 arc at wheel y = -39.764). The flange set's diagnostic cases ``*_normal_approach`` prescribe the
wheelset position (N=0) of the kinematics filmcal had before it followed that slide (first-touch position
from filmcal's placement, displaced by the normal approach along the first contact point's normal): they
show that the approach, not the plane's angle, made the difference, and are not independent references.

Grids: DX along the rail (x), DS across (s, tangent to the rail surface in the contact plane).
Area = NCON * DX * DS. Richardson: with values f1, f2, f3 on grids h, h/2, h/4, observed order
p = log2((f1 - f2) / (f2 - f3)) and extrapolated f3 + (f3 - f2) / (2**p - 1) when the differences have
one sign and 0.3 < p < 4; otherwise the extrapolation is left out (``null``) and flagged.
Film layer: boundary condition B=1 with FLXZ = h (1 + nu)(1 - 2 nu) / ((1 - nu) E) mm/MPa (= mm^3/N).

Reproduce
---------
Build CONTACT with /work/shared/tools/contact/build.sh (GIT_DIR_CONTACT=<git dir of a snapshot of
github.com/eve70a/CONTACT>; the snapshot commit used is recorded in the JSON), then::

    .venv/bin/python bench/contact/make_decks.py --set flange \\
        --contact ~/.cache/contact-build/build/bin/contact_linux64
    .venv/bin/python bench/contact/make_decks.py --set layer \\
        --contact ~/.cache/contact-build/build/bin/contact_linux64

Without ``--contact`` only the decks and profiles are written. ``--only`` selects cases by name
substring, ``--grids`` limits the grid levels (e.g. ``--grids 0,1``), ``--json`` names the output.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
DATA = ROOT / "tests" / "data" / "contact"

STEEL_E_MPA = 210000.0
STEEL_NU = 0.3
STEEL_G_MPA = STEEL_E_MPA / (2.0 * (1.0 + STEEL_NU))
INCLINATION = 1.0 / 40.0
NOMINAL_RADIUS_MM = 460.0
PROFILE_STEP_MM = 0.05

# film types of filmcal's registry (filmcal.films, BUILTIN_FILMS): thickness mm, Poisson
FILMS = {"MS": (0.09, 0.33), "HS": (0.09, 0.33), "HHS": (0.09, 0.33)}


def film_compliance(thickness_mm: float, poisson: float, modulus_mpa: float) -> float:
    """Compressible-layer compliance L_z = h (1+nu)(1-2nu) / ((1-nu) E), mm/MPa."""
    return thickness_mm * (1.0 + poisson) * (1.0 - 2.0 * poisson) / ((1.0 - poisson) * modulus_mpa)


def _fmt(v: float) -> str:
    return f"{v:g}".replace("-", "m").replace(".", "p")


def case_sets() -> dict:
    """The built-in case lists: name -> dict(rail, force_kn, eta_mm, film or None, grids)."""
    sets = {}
    # Part A: flange contact, S1002 on 60E1, 10 kN, no film; eta -3 and 0 verify the mapping on treads
    flange_grids = [(0.1, 0.05), (0.05, 0.025), (0.025, 0.0125)]
    tread_grids = [(0.1, 0.1), (0.05, 0.05), (0.025, 0.025)]
    cases = []
    for eta in (-3.0, 0.0):
        cases.append(dict(name=f"eta{_fmt(eta)}", rail="60E1", force_kn=10.0, eta_mm=eta, film=None,
                          grids=tread_grids))
    for k in range(11):
        eta = 3.0 + 0.5 * k
        cases.append(dict(name=f"eta{_fmt(eta)}", rail="60E1", force_kn=10.0, eta_mm=eta, film=None,
                          grids=flange_grids))
    h, nu = FILMS["HS"]
    cases.append(dict(name="eta5_HS_E2500", rail="60E1", force_kn=10.0, eta_mm=5.0,
                      film=dict(type="HS", thickness_mm=h, poisson=nu, modulus_mpa=2500.0),
                      grids=flange_grids))
    # Diagnostic (not an independent reference): eta 5 with filmcal's kinematics. The wheel is placed at
    # its first-touch position (filmcal's placement: tape-circle datum h = 4.837467754 mm, i.e. Z_WS =
    # -h, contact angle at the first contact point 1.214122980 rad = 69.564 deg) and displaced along that
    # point's normal by filmcal's normal approach delta = 0.051690388 mm (N=0: position prescribed),
    # instead of being lowered vertically until F = 10 kN. Compare its normal force with filmcal's
    # F / cos(theta) = 28.640 kN.
    # The HS film case likewise (filmcal's normal approach with that film: 0.073936691 mm).
    theta, z0 = 1.2141229800310873, -4.837467754177263
    for name, delta, film in (("eta5_normal_approach", 0.05169038815638765, None),
                              ("eta5_HS_E2500_normal_approach", 0.07393669145936035,
                               dict(type="HS", thickness_mm=h, poisson=nu, modulus_mpa=2500.0))):
        cases.append(dict(name=name, rail="60E1", force_kn=10.0, eta_mm=5.0, film=film, grids=flange_grids,
                          position=dict(y_ws_mm=5.0 + delta * math.sin(theta),
                                        z_ws_mm=z0 + delta * math.cos(theta), normal_approach_mm=delta,
                                        note="diagnostic: wheel displaced from first touch at eta 5 along the "
                                             "first contact point's normal by filmcal's normal approach "
                                             "(filmcal's kinematics), not lowered vertically")))
    sets["flange"] = dict(dirname="flange-60E1-10kN", wheel="S1002", rail="60E1", cases=cases)
    # Part B: film layer, S1002 on 60E2, 50/100 kN, MS/HS/HHS at E 800/2800/6300 MPa, and no film
    layer_grids = [(0.2, 0.2), (0.1, 0.1), (0.05, 0.05)]
    cases = []
    for force in (50.0, 100.0):
        for eta in (-5.0, -2.0, 0.0, 2.0):
            base = f"F{force:g}_eta{_fmt(eta)}"
            cases.append(dict(name=f"{base}_nofilm", rail="60E2", force_kn=force, eta_mm=eta, film=None,
                              grids=layer_grids))
            for ftype, e in (("MS", 800.0), ("HS", 2800.0), ("HHS", 6300.0)):
                h, nu = FILMS[ftype]
                cases.append(dict(name=f"{base}_{ftype}_E{e:g}", rail="60E2", force_kn=force, eta_mm=eta,
                                  film=dict(type=ftype, thickness_mm=h, poisson=nu, modulus_mpa=e),
                                  grids=layer_grids))
    sets["layer"] = dict(dirname="layer-S1002-60E2", wheel="S1002", rail="60E2", cases=cases)
    return sets


# ----------------------------------------------------------------------------------------------------
# profiles

def write_profiles(outdir: Path, wheel: str, rail: str) -> tuple[str, str]:
    """Sample the standard profiles and write them in CONTACT's canonical form (plain "y z" text).

    The points are those of ``filmcal profile NAME --step-mm 0.05`` (``Profile.points(0.05)``), taken
    from filmcal's Python API at full precision: the CLI's CSV rounds to 1e-6 mm, and that rounding,
    interpolated by CONTACT's spline, puts a gap noise of up to 0.5 um on the grid scale, which moves the
    max pressure of the fine grids by several MPa. Written with 8 decimals.
    """
    from filmcal.wheelrail.profiles import get_profile   # only the standard profile definitions

    names = {}
    for name, kind in ((wheel, "wheel"), (rail, "rail")):
        y, z = get_profile(name).points(PROFILE_STEP_MM)
        yz = np.column_stack([y, z]).astype(float)
        if kind == "rail":
            yz[:, 1] = -yz[:, 1]                # filmcal rail z up -> CONTACT z down
            yz = yz[np.argsort(yz[:, 0], kind="stable")]
        else:
            yz = yz[::-1]                       # wheel z radially outwards = down; y descending
        fname = f"{name.lower()}_{kind}.txt"
        np.savetxt(outdir / fname, yz, fmt="%.8f")
        names[kind] = fname
    return names["wheel"], names["rail"]


# ----------------------------------------------------------------------------------------------------
# decks

def deck_text(case: dict, grid: tuple[float, float], wheel_file: str, rail_file: str) -> str:
    dx, ds = grid
    film = case["film"]
    bound = 1 if film else 0
    cant = math.atan(INCLINATION)
    fz = case["force_kn"] * 1000.0
    pos = case.get("position")          # prescribed wheelset position (N=0) instead of the vertical force
    vs = 2000.0
    lines = [
        "% CONTACT deck written by filmcal bench/contact/make_decks.py",
        f"% case {case['name']}: S1002 wheel on {case['rail']} rail, inclination 1:40, R_nom {NOMINAL_RADIUS_MM:g} mm,",
        f"% eta {case['eta_mm']:g} mm (= Y_WS), vertical load {case['force_kn']:g} kN, grid DX {dx:g} x DS {ds:g} mm,",
        "% frictionless normal contact (T=0), steel E 210000 MPa, nu 0.3" +
        (f", film layer {film['type']} h {film['thickness_mm']:g} mm nu {film['poisson']:g} "
         f"E {film['modulus_mpa']:g} MPa (B=1, FLXZ)" if film else ", no film"),
        "",
        "  1  MODULE",
        f" 12{bound}0{0 if pos else 1}00        C-P-B-T-N-F-S   CONFIG 1 (right wheel), PVTIME 2, BOUND, TANG 0, "
        f"NORM {'0 (Z_WS)' if pos else '1 (FZ)'}",
        " 0022033        V-L-D-C-M-Z-E   DISCNS 2 (planar), INFLCF 2, ZTRACK 3, EWHEEL 3",
        " 0001311        H-G-I-A-O-W-R   MATFIL 1, OUTPUT 3, FLOW 1, RETURN 1",
        "   999   100   30   1   1e-6   4000000      MAXGS, MAXIN, MAXNR, MAXOUT, EPS, NPOT_MAX",
        "   0.3   0.3                               FSTAT, FKIN (unused, T=0)",
        f"   {STEEL_NU:g}   {STEEL_NU:g}   {STEEL_G_MPA:.4f}   {STEEL_G_MPA:.4f}    POISS 1,2, GG 1,2",
    ]
    if film:
        flxz = film_compliance(film["thickness_mm"], film["poisson"], film["modulus_mpa"])
        lines.append(f"   {flxz:.8e}                          FLXZ (mm^3/N)")
    lines += [
        f"   {dx:g}   {ds:g}   1.0   90d   8.0   4.0      DX, DS, DQREL, A_SEP, D_SEP, D_COMB",
        f"   -1.0   0.0   0.0   {cant:.12f}        GAUGHT (<0: absolute placement), RAILY0, RAILZ0, CANT (rad)",
        f"   '{rail_file}'   0   1.0   0.0   -1       RFNAME, MIRRORY, SCALEYZ, SMOOTH, MIRRORZ",
        "   0.0   0.0   0.0   0.0   0.0   0.0          DYRAIL, DZRAIL, DROLLR, VYRAIL, VZRAIL, VROLLR",
        f"   -140.0   -70.0   {NOMINAL_RADIUS_MM:g}   0.0        FBDIST, FBPOS, NOMRADW, YTAPE",
        f"   '{wheel_file}'   0   1.0   0.0   -1      WFNAME, MIRRORY, SCALEYZ, SMOOTH, MIRRORZ",
        (f"   0.0   {pos['y_ws_mm']:.9f}   {pos['z_ws_mm']:.9f}   0.0   0.0   0.0     S_WS, Y_WS, Z_WS, ROLL, YAW, PITCH"
         if pos else
         f"   0.0   {case['eta_mm']:g}   {fz:g}   0.0   0.0   0.0     S_WS, Y_WS (= eta), FZ_WS, ROLL, YAW, PITCH"),
        f"   {vs:g}   0.0   0.0   0.0   0.0   {-vs / NOMINAL_RADIUS_MM:.8f}   VS_WS, VY, VZ, VROLL, VYAW, VPITCH",
        "",
        "  0  MODULE",
        "",
    ]
    return "\n".join(lines)


def deck_name(case: dict, level: int) -> str:
    return f"{case['name']}_g{level}"


# ----------------------------------------------------------------------------------------------------
# parsing

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?"


def _after(text: str, header: str, nvals: int, skip_lines: int = 1) -> list[float]:
    """The numbers on the line `skip_lines` below the line containing `header`."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if header in line:
            vals = re.findall(_NUM, lines[i + skip_lines])
            return [float(v) for v in vals[:nvals]]
    raise ValueError(f"{header!r} not found")


def parse_out(text: str) -> dict:
    """Global and per-patch numbers of one case from CONTACT's .out file."""
    res = {}
    fx = _after(text, "FX(TR)      FY(TR)      FZ(TR)", 6)
    res["fy_tr_n"], res["fz_tr_n"] = fx[1], fx[2]
    wpos = _after(text, "S_WS        Y_WS        Z_WS", 6)
    res["y_ws_mm"], res["z_ws_mm"] = wpos[1], wpos[2]
    patches = []
    for block in text.split("----- DATA FOR CONTACT PATCH")[1:]:
        p = {}
        ref = _after(block, "XCP(TR)     YCP(TR)     ZCP(TR)", 6)
        p["ycp_tr_mm"], p["zcp_tr_mm"], p["deltcp_tr_rad_4dp"], p["ycp_r_mm"], p["zcp_r_mm"] = ref[1:6]
        refw = _after(block, "XCP(W)      YCP(W)      ZCP(W)", 3)
        p["ycp_w_mm"], p["zcp_w_mm"] = refw[1], refw[2]
        fn = _after(block, "FN          FX          FS", 1)
        p["fn_n"] = fn[0]
        ap = _after(block, "APPROACH     PMAX", 5)
        p["pen_mm"], p["pmax_out_mpa"] = ap[3], ap[4]
        st = _after(block, "NPOT   NCON", 2)
        p["npot"], p["ncon"] = int(st[0]), int(st[1])
        patches.append(p)
    res["patches"] = patches
    return res


def _ffloat(v: str) -> float:
    """A Fortran number, also with a 3-digit exponent written without the E ('0.41-318')."""
    try:
        return float(v)
    except ValueError:
        return float(re.sub(r"(\d)([-+]\d+)$", r"\1E\2", v))


def parse_mat(path: Path) -> dict:
    """Header numbers and element pressures of one patch's .mat file (A=1: elements in contact)."""
    with open(path) as fh:
        rows = [line for line in fh if line.strip() and not line.lstrip().startswith("%")]
    nums = [[float(v) for v in re.findall(_NUM, line)] for line in rows[:6]]
    rail, wheel, cpref, grid = nums[0], nums[1], nums[2], nums[3]   # then material and friction lines
    tab = np.array([[_ffloat(v) for v in line.split()] for line in rows[6:]]) if len(rows) > 6 \
        else np.zeros((0, 11))
    mx, my = int(grid[0]), int(grid[1])
    xl, yl, dx, dy = grid[2:6]
    i = tab[:, 0].astype(int) - 1
    ix, iy = i % mx, i // mx
    pn = tab[:, 4]
    inside = pn > 0
    x = xl + (ix + 0.5) * dx
    s = yl + (iy + 0.5) * dy
    w = pn[inside]
    out = dict(
        roll_r_rad=rail[5], y_w_tr_mm=wheel[1], z_w_tr_mm=wheel[2],
        ycp_r_mm=cpref[1], zcp_r_mm=cpref[2], delt_cp_r_rad=cpref[3], ycp_w_mm=cpref[5], zcp_w_mm=cpref[6],
        mx=mx, my=my, dx_mm=dx, ds_mm=dy, xl_mm=xl, sl_mm=yl,
        ncon_mat=int(inside.sum()), pmax_mpa=float(pn.max()) if len(pn) else 0.0,
        force_sum_n=float(w.sum() * dx * dy),
        centroid_x_mm=float((x[inside] * w).sum() / w.sum()) if w.size else None,
        centroid_s_mm=float((s[inside] * w).sum() / w.sum()) if w.size else None,
        s_min_mm=float(s[inside].min() - 0.5 * dy) if w.size else None,
        s_max_mm=float(s[inside].max() + 0.5 * dy) if w.size else None,
        x_min_mm=float(x[inside].min() - 0.5 * dx) if w.size else None,
        x_max_mm=float(x[inside].max() + 0.5 * dx) if w.size else None,
        touches_edge=bool(((ix[inside] == 0) | (ix[inside] == mx - 1) | (iy[inside] == 0)
                           | (iy[inside] == my - 1)).any()),
    )
    return out


def run_case(contact: Path, deck: Path, profiles: list[Path], timeout_s: float) -> dict:
    """Run CONTACT on one deck in a scratch directory; return the parsed numbers."""
    with tempfile.TemporaryDirectory(prefix="contact_") as tmp:
        tmp = Path(tmp)
        shutil.copy(deck, tmp / deck.name)
        for p in profiles:
            shutil.copy(p, tmp / p.name)
        env = dict(os.environ, OMP_NUM_THREADS="1")
        t0 = time.time()
        proc = subprocess.run([str(contact), "2", deck.stem], cwd=tmp, env=env, stdin=subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=timeout_s)
        elapsed = time.time() - t0
        outfile = tmp / f"{deck.stem}.out"
        text = outfile.read_text(errors="replace") if outfile.exists() else ""
        if proc.returncode != 0 or "ended succesfully" not in (proc.stdout + text):
            tail = (proc.stdout + proc.stderr)[-1500:]
            return dict(ok=False, elapsed_s=elapsed, error=tail)
        res = parse_out(text)
        mats = sorted(tmp.glob(f"{deck.stem}.0001*.mat"))
        if len(mats) != len(res["patches"]):
            return dict(ok=False, elapsed_s=elapsed, error=f"{len(mats)} mat files for {len(res['patches'])} patches")
        for p, m in zip(res["patches"], mats):
            p.update(parse_mat(m))
        res.update(ok=True, elapsed_s=round(elapsed, 2))
        return res


# ----------------------------------------------------------------------------------------------------
# summary per grid and extrapolation

def summarize(res: dict, grid: tuple[float, float], case: dict) -> dict:
    """The reported numbers of one run (all patches together plus per patch)."""
    pats = res["patches"]
    roll = pats[0]["roll_r_rad"] if pats else 0.0
    out = dict(dx_mm=grid[0], ds_mm=grid[1], n_patches=len(pats))
    per = []
    for p in pats:
        area = p["ncon"] * p["dx_mm"] * p["ds_mm"]
        delt_tr = p["delt_cp_r_rad"] + roll        # rail roll is -CANT for the right rail
        c = math.cos(p["delt_cp_r_rad"])
        per.append(dict(
            contact_area_mm2=area, ncon=p["ncon"], npot=p["npot"], max_pressure_mpa=p["pmax_mpa"],
            normal_force_kn=p["fn_n"] / 1000.0, contact_angle_deg=-math.degrees(delt_tr),
            ref_y_track_mm=p["ycp_tr_mm"], ref_z_track_mm=p["zcp_tr_mm"],
            ref_y_rail_mm=p["ycp_r_mm"], ref_y_wheel_mm=p["ycp_w_mm"],
            approach_normal_mm=p["pen_mm"],
            centroid_s_mm=p["centroid_s_mm"],
            centroid_y_rail_mm=(p["ycp_r_mm"] + p["centroid_s_mm"] * c) if p["centroid_s_mm"] is not None else None,
            centroid_y_wheel_mm=(p["ycp_w_mm"] + p["centroid_s_mm"] * c) if p["centroid_s_mm"] is not None else None,
            patch_s_range_mm=[p["s_min_mm"], p["s_max_mm"]], patch_x_range_mm=[p["x_min_mm"], p["x_max_mm"]],
            grid_used_mm=[p["dx_mm"], p["ds_mm"]], touches_potential_edge=p["touches_edge"],
        ))
    if per:
        main = max(range(len(per)), key=lambda k: per[k]["normal_force_kn"])
        out.update(
            contact_area_mm2=sum(q["contact_area_mm2"] for q in per),
            max_pressure_mpa=max(q["max_pressure_mpa"] for q in per),
            normal_force_kn=sum(q["normal_force_kn"] for q in per),
            vertical_force_kn=res["fz_tr_n"] / 1000.0, lateral_force_kn=res["fy_tr_n"] / 1000.0,
            contact_angle_deg=per[main]["contact_angle_deg"],
            ref_y_rail_mm=per[main]["ref_y_rail_mm"], ref_y_wheel_mm=per[main]["ref_y_wheel_mm"],
            centroid_y_rail_mm=per[main]["centroid_y_rail_mm"],
            centroid_y_wheel_mm=per[main]["centroid_y_wheel_mm"],
            approach_normal_mm=per[main]["approach_normal_mm"],
            wheelset_z_mm=res["z_ws_mm"],
            grid_as_requested=all(abs(q["grid_used_mm"][0] - grid[0]) < 1e-9 and
                                  abs(q["grid_used_mm"][1] - grid[1]) < 1e-9 for q in per),
            touches_potential_edge=any(q["touches_potential_edge"] for q in per),
        )
    out["patches"] = per
    out["elapsed_s"] = res["elapsed_s"]
    return out


EXTRAP_KEYS = ("contact_area_mm2", "max_pressure_mpa", "normal_force_kn", "contact_angle_deg",
               "approach_normal_mm", "ref_y_rail_mm", "ref_y_wheel_mm", "centroid_y_rail_mm")


def richardson(f1: float, f2: float, f3: float) -> dict:
    """Observed order and extrapolated value from three grids refined by 2."""
    d1, d2 = f1 - f2, f2 - f3
    if d2 == 0.0 and d1 == 0.0:
        return dict(value=f3, order=None, note="identical on all grids")
    if d1 * d2 <= 0.0 or d2 == 0.0:
        return dict(value=None, order=None, note="non-monotone over the grids")
    p = math.log2(d1 / d2)
    if not 0.3 < p < 4.0:
        return dict(value=None, order=p, note="order out of range")
    return dict(value=f3 - d2 / (2.0 ** p - 1.0), order=p, note="")


def extrapolate(runs: list[dict]) -> dict:
    ok = [r for r in runs if r.get("contact_area_mm2") is not None]
    if len(ok) < 3:
        return {}
    out = {}
    for key in EXTRAP_KEYS:
        vals = [r.get(key) for r in ok[-3:]]
        if any(v is None for v in vals):
            continue
        out[key] = richardson(*vals)
    # fixed-order variants for the two headline quantities (area: first order, pmax: second order)
    a = [r["contact_area_mm2"] for r in ok[-3:]]
    pm = [r["max_pressure_mpa"] for r in ok[-3:]]
    out["contact_area_mm2_order1"] = a[2] + (a[2] - a[1])
    out["max_pressure_mpa_order2"] = pm[2] + (pm[2] - pm[1]) / 3.0
    return out


# ----------------------------------------------------------------------------------------------------

def snapshot_commit(contact: Path | None) -> str | None:
    for cand in ([contact.parent.parent.parent / "src" / "SNAPSHOT.txt"] if contact else []) + \
            [Path.home() / ".cache" / "contact-build" / "src" / "SNAPSHOT.txt"]:
        if cand.exists():
            return cand.read_text().strip()
    return None


def _round(obj, sig: int = 7):
    if isinstance(obj, float):
        return float(f"{obj:.{sig}g}")
    if isinstance(obj, dict):
        return {k: _round(v, sig) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_round(v, sig) for v in obj]
    return obj


def dump_json(doc: dict) -> str:
    """Compact JSON: floats to 7 significant digits, one line per run; a single patch's details are kept
    in the run's own fields (its ``patches`` list is dropped: it repeats them)."""
    doc = _round(doc)
    for case in doc.get("cases", {}).values():
        for run in case.get("runs", []):
            if run and run.get("n_patches") == 1 and run.get("patches"):
                p = run.pop("patches")[0]
                for k in ("ncon", "npot", "centroid_s_mm", "patch_s_range_mm", "patch_x_range_mm",
                          "ref_y_track_mm", "ref_z_track_mm"):
                    run[k] = p[k]
    head = {k: v for k, v in doc.items() if k != "cases"}
    lines = ["{"] + [f" {json.dumps(k)}: {json.dumps(v)}," for k, v in head.items()] + [' "cases": {']
    cases = []
    for name, case in doc.get("cases", {}).items():
        body = {k: v for k, v in case.items() if k != "runs"}
        runs = ",\n".join(f"    {json.dumps(r)}" for r in case.get("runs", []))
        cases.append(f"  {json.dumps(name)}: {json.dumps(body)[:-1]}, \"runs\": [\n{runs}\n  ]}}")
    lines.append(",\n".join(cases))
    lines += [" }", "}", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    sets = case_sets()
    ap = argparse.ArgumentParser(
        description="Write CONTACT (E.A.H. Vollebregt, open source) input decks and profile files for "
                    "filmcal's wheel-rail reference cases, optionally run CONTACT on them and collect its "
                    "contact area, max pressure, normal force, contact angle, reference point and approach "
                    "per grid, with a Richardson extrapolation, into a JSON next to the decks. "
                    "Case sets: 'flange' (S1002/60E1, 10 kN, eta -3, 0, 3..8 mm, and eta 5 with an HS film "
                    "E 2500 MPa) and 'layer' (S1002/60E2, 50/100 kN, eta -5, -2, 0, 2 mm, no film and "
                    "MS/HS/HHS films at E 800/2800/6300 MPa). The flange set also holds two diagnostic cases "
                    "'*_normal_approach' (eta 5, wheel displaced along the contact normal from first touch "
                    "as filmcal's model did before it followed the slide, position prescribed). See the module docstring for the "
                    "geometry mapping (Y_WS = eta, absolute rail placement, CANT = atan(1/40)).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--set", choices=sorted(sets), required=True, help="which case list")
    ap.add_argument("--outdir", type=Path, default=None,
                    help="directory for decks, profiles and JSON (default tests/data/contact/<set dir>)")
    ap.add_argument("--contact", type=Path, default=None,
                    help="path of the CONTACT program (contact_linux64); without it only decks are written")
    ap.add_argument("--only", action="append", default=None,
                    help="run only cases whose name contains this string (repeatable)")
    ap.add_argument("--grids", default=None, help="comma-separated grid levels to run (0 = coarsest)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per CONTACT run")
    ap.add_argument("--json", type=Path, default=None, help="output JSON (default <outdir>/<set dir>.json)")
    ap.add_argument("--merge", action="store_true",
                    help="start from an existing JSON and replace only the cases/grids run now")
    args = ap.parse_args(argv)

    spec = sets[args.set]
    outdir = args.outdir or (DATA / spec["dirname"])
    outdir.mkdir(parents=True, exist_ok=True)
    wheel_file, rail_file = write_profiles(outdir, spec["wheel"], spec["rail"])
    levels = None if args.grids is None else {int(v) for v in args.grids.split(",")}
    cases = [c for c in spec["cases"] if not args.only or any(s in c["name"] for s in args.only)]

    decks = []
    for case in spec["cases"]:
        for lev, grid in enumerate(case["grids"]):
            path = outdir / f"{deck_name(case, lev)}.inp"
            path.write_text(deck_text(case, grid, wheel_file, rail_file))
            if case in cases and (levels is None or lev in levels):
                decks.append((case, lev, grid, path))
    print(f"wrote {sum(len(c['grids']) for c in spec['cases'])} decks and 2 profiles to {outdir}")
    if args.contact is None:
        return 0

    jpath = args.json or (outdir / f"{spec['dirname']}.json")
    doc = json.loads(jpath.read_text()) if (args.merge and jpath.exists()) else {}
    doc.update(
        description=f"CONTACT reference numbers, case set '{args.set}' (bench/contact/make_decks.py)",
        contact_snapshot=snapshot_commit(args.contact),
        generated=datetime.datetime.now().isoformat(timespec="seconds"),
        wheel=spec["wheel"], rail=spec["rail"], rail_inclination=INCLINATION,
        nominal_radius_mm=NOMINAL_RADIUS_MM, steel=dict(modulus_mpa=STEEL_E_MPA, poisson=STEEL_NU),
        profile_files=dict(wheel=wheel_file, rail=rail_file, step_mm=PROFILE_STEP_MM,
                           source="filmcal Profile.points(0.05) (= filmcal profile NAME --step-mm 0.05, unrounded); rail z negated, wheel order reversed"),
        mapping=dict(config="right wheel (C1=1), absolute rail placement GAUGHT=-1 RAILY0=RAILZ0=0, "
                            "CANT=atan(1/40), FBDIST=-140 FBPOS=-70 (wheel origin under the wheelset "
                            "centre), NOMRADW=460, YTAPE=0, Y_WS=eta, FZ_WS=F prescribed (N=1)",
                     discretisation="D=2 planar contact (weighted reference point and angle), "
                                    "piecewise-constant half-space influence coefficients (C3=2)",
                     contact_angle="-DELTTR in degrees: overlap-weighted mean surface inclination",
                     area="NCON * DX * DS"),
        richardson="three grids refined by 2 in both directions; observed order p = log2((f1-f2)/(f2-f3)), "
                   "value f3 + (f3-f2)/(2^p-1); *_order1 / *_order2: fixed-order variants",
    )
    doc.setdefault("cases", {})
    for case, lev, grid, path in decks:
        entry = doc["cases"].setdefault(case["name"], {})
        entry.update(eta_mm=case["eta_mm"], force_kn=case["force_kn"], film=case["film"],
                     grids_mm=[list(g) for g in case["grids"]])
        if case.get("position"):
            entry["prescribed_position"] = case["position"]
            entry["force_kn"] = None
        if case["film"]:
            f = case["film"]
            entry["film"] = dict(f, flxz_mm3_per_n=film_compliance(f["thickness_mm"], f["poisson"],
                                                                   f["modulus_mpa"]))
        runs = entry.setdefault("runs", [None] * len(case["grids"]))
        print(f"{case['name']} grid {grid} ...", end=" ", flush=True)
        res = run_case(args.contact, path, [outdir / wheel_file, outdir / rail_file], args.timeout)
        if not res["ok"]:
            print("FAILED", res.get("error", "")[-300:])
            runs[lev] = dict(dx_mm=grid[0], ds_mm=grid[1], deck=path.name, error=res.get("error", "")[-600:])
        else:
            runs[lev] = dict(summarize(res, grid, case), deck=path.name)
            r = runs[lev]
            print(f"A {r.get('contact_area_mm2', float('nan')):.4f} pmax {r.get('max_pressure_mpa', float('nan')):.1f} "
                  f"angle {r.get('contact_angle_deg', float('nan')):.4f} patches {r['n_patches']} "
                  f"({res['elapsed_s']:.1f} s){' EDGE' if r.get('touches_potential_edge') else ''}")
        entry["extrapolated"] = extrapolate([r for r in runs if r])
        jpath.write_text(dump_json(doc))
    print(f"wrote {jpath}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
