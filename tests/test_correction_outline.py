"""Outlines without film: offsets against analytic shapes, the wheel-rail rule against the model, the command."""
from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from filmcal.correction import (ModelOutlines, SphereCorrector, correct_outline, hausdorff_distance_mm,
                                offset_outline, outline_area_mm2, shrink_outline, signed_distance_mm)
from filmcal.correction.outline import FIELD_SIDES
from filmcal.hertz import hertz_radius_mm
from filmcal.wheelrail import FilmLayer, solve_wheel_rail

REPO = Path(__file__).resolve().parents[1]


def circle(radius, n=4000, centre=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([centre[0] + radius * np.cos(t), centre[1] + radius * np.sin(t)])


def radii(rings, centre=(0.0, 0.0)):
    pts = np.vstack(rings)
    return np.hypot(pts[:, 0] - centre[0], pts[:, 1] - centre[1])


def test_signed_distance_matches_analytic_shapes():
    rng = np.random.default_rng(0)
    points = rng.uniform(-10, 10, (5000, 2))
    d = signed_distance_mm(circle(7.0), points)
    assert d == pytest.approx(np.hypot(*points.T) - 7.0, abs=1e-4)  # polygon sagitta 7 (pi/4000)^2 / 2
    ring_with_hole = [circle(7.0), circle(3.0)]  # even-odd: the inner circle is a hole
    d = signed_distance_mm(ring_with_hole, points)
    r = np.hypot(*points.T)
    expected = np.where(r < 5.0, 3.0 - r, r - 7.0)
    assert d == pytest.approx(expected, abs=1e-4)
    square = np.array([[0, 0], [0, 10], [10, 10], [10, 0]], float)  # clockwise on purpose
    outside_corner = np.array([[13.0, 14.0]])
    assert signed_distance_mm(square, outside_corner)[0] == pytest.approx(5.0, abs=1e-12)
    assert signed_distance_mm(square, [[2.0, 5.0]])[0] == pytest.approx(-2.0, abs=1e-12)


def test_circle_offset_gives_the_exact_radius():
    inner = offset_outline(circle(7.0), 0.5)
    assert len(inner) == 1
    assert radii(inner) == pytest.approx(6.5, abs=2e-4)
    outer = offset_outline(circle(7.0), -0.3)
    assert radii(outer) == pytest.approx(7.3, abs=2e-4)
    rings, scale = shrink_outline(circle(7.0, centre=(20.0, 15.0)), [math.pi * 6.2**2, math.pi * 7.4**2])
    assert scale == pytest.approx([0.8, -0.4], abs=2e-4)
    assert radii(rings[0], (20.0, 15.0)) == pytest.approx(6.2, abs=2e-4)
    assert radii(rings[1], (20.0, 15.0)) == pytest.approx(7.4, abs=2e-4)


def test_square_offsets_keep_corners_inside_and_round_them_outside():
    """Inward offset of a convex polygon keeps its corners: (10 - 2)^2; outward adds the edges and a
    quarter circle at each corner: 100 + 4 * 10 + pi."""
    square = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    assert outline_area_mm2(offset_outline(square, 1.0)) == pytest.approx(64.0, abs=0.02)
    assert outline_area_mm2(offset_outline(square, -1.0)) == pytest.approx(140.0 + math.pi, abs=0.02)
    # a bar narrower than twice the offset between two squares: the shape splits in two, without loops;
    # each square shrinks to 4.4 x 4.4 plus a sliver where the bar was attached, between the quarter
    # discs of radius 0.8 round the bar's corners: 2 * integral_0^0.5 (0.8 - sqrt(0.64 - u^2)) du
    dumbbell = np.array([[0, 0], [6, 0], [6, 2.5], [8, 2.5], [8, 0], [14, 0], [14, 6], [8, 6], [8, 3.5],
                         [6, 3.5], [6, 6], [0, 6]], float)
    split = offset_outline(dumbbell, 0.8)
    disc_part = 0.25 * math.sqrt(0.64 - 0.25) + 0.32 * math.asin(0.5 / 0.8)
    sliver = 2 * (0.8 * 0.5 - disc_part)
    assert len(split) == 2
    assert outline_area_mm2(split) == pytest.approx(2 * (4.4**2 + sliver), abs=0.01)


def test_hausdorff_distance_of_concentric_and_shifted_circles():
    assert hausdorff_distance_mm(circle(7.0), circle(6.5)) == pytest.approx(0.5, abs=1e-3)
    assert hausdorff_distance_mm(circle(7.0), circle(7.0, centre=(0.3, 0.0))) == pytest.approx(0.3, abs=1e-3)


class ConstantEnlargement:
    """Printed radius = a_Hertz + delta, independent of E (as in tests/test_correction_sphere.py)."""

    def __init__(self, delta_mm: float) -> None:
        self.delta = delta_mm

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        e, r, f = np.broadcast_arrays(np.asarray(modulus_mpa, float), sphere_radius_mm, force_n)
        return hertz_radius_mm(r, f) + self.delta, np.zeros(e.shape)


def test_sphere_outline_is_the_hertz_circle_and_the_band_brackets_it():
    n = 4000
    posterior = {"modulus_mpa": np.full(n, 2800.0), "poisson": np.full(n, 0.33), "sigma_mm": np.full(n, 0.05)}
    a0 = hertz_radius_mm(450.0, 75e3)
    centre = (12.0, 9.0)
    measured = circle(a0 + 1.1, centre=centre)
    corrected = SphereCorrector(ConstantEnlargement(1.1), posterior, random_state=0).correct(
        a0 + 1.1, 450.0, 75e3)
    out = correct_outline(measured, corrected)
    assert out.rule == "uniform offset"
    mean_radius = math.sqrt(float(corrected.area_mm2) / math.pi)
    assert mean_radius == pytest.approx(a0, abs=0.01)  # scatter 0.05 mm averages out
    assert radii(out.mean_mm, centre) == pytest.approx(mean_radius, abs=2e-4)
    lo, hi = corrected.area_ci90_mm2
    assert radii(out.lo_mm, centre) == pytest.approx(math.sqrt(lo / math.pi), abs=2e-4)
    assert radii(out.hi_mm, centre) == pytest.approx(math.sqrt(hi / math.pi), abs=2e-4)
    assert radii(out.lo_mm, centre).max() < a0 < radii(out.hi_mm, centre).min()


def to_image(rings, field_side, origin):
    """Model-frame rings (x along the rail, y to the field side) drawn in an image frame."""
    rotation = FIELD_SIDES[field_side]
    return [r @ rotation + origin for r in rings]  # rotation is orthogonal: its inverse is its transpose


def to_model(rings, field_side, origin):
    rotation = FIELD_SIDES[field_side]
    return [(r - origin) @ rotation.T for r in rings]


@pytest.mark.parametrize("offset_mm, field_side", [(-3.0, "right"), (2.0, "down")])
def test_wheel_rail_rule_reproduces_the_model_outline_without_film(offset_mm, field_side):
    """A film outline solved at E = 2000 MPa, shrunk to the area without film by the model's shift
    taken at E = 2800 MPa, lands on the model's outline without film within its grid spacing (0.1 mm);
    a uniform offset to the same area misses it by several grid spacings (the film enlarges the patch
    unevenly round its edge)."""
    force = 100e3
    bare = solve_wheel_rail(offset_mm, force)
    rule_film = solve_wheel_rail(offset_mm, force, film=FilmLayer(2800.0, 0.33, 0.09))
    imprint = solve_wheel_rail(offset_mm, force, film=FilmLayer(2000.0, 0.33, 0.09))
    origin = np.array([40.0, 30.0])
    measured = to_image(imprint.outline_mm, field_side, origin)
    target = outline_area_mm2(bare.outline_mm)
    model = ModelOutlines(rule_film.outline_mm, bare.outline_mm)
    out = correct_outline(measured, (target, 0.97 * target, 1.03 * target), model, field_side=field_side)
    assert out.rule == "wheel-rail model shift"
    assert outline_area_mm2(out.mean_mm) == pytest.approx(target, rel=2e-3)
    assert outline_area_mm2(out.lo_mm) < outline_area_mm2(out.mean_mm) < outline_area_mm2(out.hi_mm)
    # the film at 2000 MPa enlarges more than the rule's 2800 MPa: more than the full model shift
    assert out.shift_scale[0] > 1.0
    rule_error = hausdorff_distance_mm(to_model(out.mean_mm, field_side, origin), bare.outline_mm)
    uniform = correct_outline(measured, (target, 0.97 * target, 1.03 * target))
    uniform_error = hausdorff_distance_mm(to_model(uniform.mean_mm, field_side, origin), bare.outline_mm)
    assert rule_error < 0.1
    assert uniform_error > 0.2 and uniform_error > 3 * rule_error


def test_bad_input():
    with pytest.raises(ValueError, match="at least 3 vertices"):
        offset_outline(np.array([[0.0, 0.0], [1.0, 1.0]]), 0.1)
    with pytest.raises(ValueError, match="finite"):
        offset_outline(np.array([[0.0, 0.0], [1.0, np.nan], [1.0, 0.0]]), 0.1)
    with pytest.raises(ValueError, match="distance_mm"):
        offset_outline(circle(5.0), float("inf"))
    with pytest.raises(ValueError, match="leaves nothing"):
        offset_outline(circle(5.0), 6.0)
    with pytest.raises(ValueError, match="area_mm2"):
        shrink_outline(circle(5.0), -1.0)
    with pytest.raises(ValueError, match="corrected areas"):
        correct_outline(circle(5.0), (50.0, -1.0, 60.0))
    with pytest.raises(ValueError, match="mean, lo, hi"):
        correct_outline(circle(5.0), (50.0, 60.0))
    with pytest.raises(ValueError, match="field_side"):
        correct_outline(circle(5.0), (50.0, 45.0, 55.0), field_side="north")


def test_command_reads_an_imprint_and_writes_the_corrected_outline(quick_study, tmp_path):
    """Wheel-rail form end to end: a red ellipse scanned at 600 dpi (metadata), the study's edge-model posterior."""
    from filmcal.study import Study

    study = quick_study[0]
    result, _, _ = Study(study).posterior("HS", model="edge/small")
    e_median = result.modulus_mpa["median"]
    h = 25.4 / 600
    semi_x, semi_y = 7.2 / h, 6.6 / h  # pixels
    rows, cols = 420, 440
    r, c = np.mgrid[0:rows, 0:cols]
    sub = (np.arange(4) + 0.5) / 4
    cover = sum((((c + dx - 220) / semi_x) ** 2 + ((rows - r - dy - 205) / semi_y) ** 2 <= 1)
                for dx in sub for dy in sub) / 16.0
    rgb = np.array([245.0, 243.0, 240.0]) * (1 - cover[..., None]) + np.array([215.0, 60.0, 120.0]) * cover[..., None]
    rgb += 3.0 * np.random.default_rng(0).standard_normal(rgb.shape)
    scan = tmp_path / "imprint.png"
    Image.fromarray(np.clip(np.rint(rgb), 0, 255).astype(np.uint8)).save(scan, dpi=(600, 600))
    outline_csv = tmp_path / "outline.csv"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    cmd = [sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--scan", str(scan), "--offset-mm=-3",
           "--force-kn", "100", "--measured-area-std-mm2", "0.5", "--study-dir", str(study), "--imprint-model", "edge", "--kinematics", "small",
           "--outline-out", str(outline_csv), "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    true_area = math.pi * 7.2 * 6.6
    assert abs(out["measured_area_mm2"] - true_area) <= out["measured_area_std_mm2"]
    assert out["measured_area_std_mm2"] < 0.01 * true_area
    # the correction is about the model's area ratio at the posterior median of E
    ratio = solve_wheel_rail(-3.0, 100e3).area_mm2 / solve_wheel_rail(
        -3.0, 100e3, film=FilmLayer(e_median, 0.33, 0.09)).area_mm2
    lo, hi = out["area_ci90_mm2"]
    assert lo < out["measured_area_mm2"] * ratio < hi
    assert out["area_mm2"] == pytest.approx(out["measured_area_mm2"] * ratio, rel=0.02)
    with open(outline_csv, newline="") as fh:
        rows_csv = list(csv.DictReader(fh))
    assert set(rows_csv[0]) == {"part", "ring", "x_mm", "y_mm"}
    parts = {}
    for row in rows_csv:
        parts.setdefault(row["part"], []).append((float(row["x_mm"]), float(row["y_mm"])))
    assert set(parts) == {"measured", "mean", "lo", "hi"}
    areas = {k: outline_area_mm2(np.array(v)) for k, v in parts.items()}
    assert areas["measured"] == pytest.approx(out["measured_area_mm2"], rel=1e-6)
    assert areas["mean"] == pytest.approx(out["area_mm2"], rel=2e-3)
    assert areas["lo"] == pytest.approx(lo, rel=2e-3) and areas["hi"] == pytest.approx(hi, rel=2e-3)
    centre = np.array([220 * h, 205 * h])
    assert np.all(signed_distance_mm(np.array(parts["measured"]), np.array(parts["hi"])) < 0)  # inside the imprint
    assert np.mean(np.array(parts["mean"]), axis=0) == pytest.approx(centre, abs=0.3)
