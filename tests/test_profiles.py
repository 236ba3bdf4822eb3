"""Wheel and rail profiles (S1002, 60E1, 60E2), custom CSV profiles, placement and gap."""
from __future__ import annotations

import math

import numpy as np
import pytest

from filmcal.cli import main
from filmcal.wheelrail.placement import offset_range_mm, place_wheel_on_rail
from filmcal.wheelrail.profiles import (
    PROFILE_NAMES, PolynomialSection, Profile, flange_height_mm, flange_thickness_mm,
    get_profile, head_width_mm, load_profile_csv,
)

# Half the horizontal distance between the tangent points that bound the crown
# arc in EN 13674-1 (60E1: 20.456 mm, 60E2: 23.778 mm).
CROWN_HALF_WIDTH_MM = {"60E1": 20.456 / 2, "60E2": 23.778 / 2}
CROWN_RADIUS_MM = {"60E1": 300.0, "60E2": 200.0}


def _fit_circle(y: np.ndarray, z: np.ndarray) -> float:
    """Radius of the least-squares circle through points (algebraic Kasa fit)."""
    a = np.column_stack([y, z, np.ones_like(y)])
    b = y**2 + z**2
    c1, c2, c3 = np.linalg.lstsq(a, b, rcond=None)[0]
    return math.sqrt(c3 + (c1 / 2) ** 2 + (c2 / 2) ** 2)


# ---------------------------------------------------------------- standard profiles

@pytest.mark.parametrize("name", PROFILE_NAMES)
def test_joints_are_continuous_in_value_and_slope(name):
    profile = get_profile(name)
    for j in profile.joints():
        print(f"{name} joint y={j.y_mm:9.4f} {j.left:>26} | {j.right:<26} "
              f"dz={j.z_mismatch_mm:+.2e} mm  dslope={j.slope_mismatch:+.2e}")
        # The S1002 coefficients are published to 9-10 digits: the worst joint
        # (D|C at y = -35) is off by 0.12 um; the tangent-arc rail heads are exact.
        assert abs(j.z_mismatch_mm) < 2e-4
        assert abs(j.slope_mismatch) < 1e-5


@pytest.mark.parametrize("name", PROFILE_NAMES)
def test_sampled_curve_has_no_kink_at_joints(name):
    # Second method: the slope of a parabola through three curve points on
    # each side of a joint (not using the joint itself), extrapolated to it.
    profile = get_profile(name)
    t = np.array([1.0, 2.0, 3.0]) * 1e-3
    for j in profile.joints():
        left = np.polyfit(-t, profile.z(j.y_mm - t), 2)[1]
        right = np.polyfit(t, profile.z(j.y_mm + t), 2)[1]
        assert abs(math.atan(right) - math.atan(left)) < 1e-3, j


def test_s1002_tread_datum_and_flange_height():
    wheel = get_profile("S1002")
    assert wheel.z(0.0) == pytest.approx(0.0, abs=1e-12)
    assert flange_height_mm(wheel) == pytest.approx(28.0, abs=1e-6)
    # The flange tip is the top of the R12 arc centred at y = -55.
    y, z = wheel.points(0.05)
    assert y[np.argmax(z)] == pytest.approx(-55.0, abs=0.05)


def test_s1002_flange_thickness():
    wheel = get_profile("S1002")
    assert flange_thickness_mm(wheel) == pytest.approx(32.5, abs=1e-3)
    # Second method: linear interpolation of the sampled flange face at z = 10.
    y, z = wheel.points(0.05)
    face = (y > -55) & (y < 0)
    y_face = np.interp(10.0, z[face][::-1], y[face][::-1])
    assert y_face + 70.0 == pytest.approx(32.5, abs=0.01)
    # The flange narrows towards its tip.
    assert flange_thickness_mm(wheel, height_mm=5.0) > 32.5 > flange_thickness_mm(wheel, height_mm=15.0)


def test_s1002_flange_face_angle_is_70_degrees():
    wheel = get_profile("S1002")
    assert math.degrees(math.atan(-wheel.slope(-39.0))) == pytest.approx(70.0, abs=0.01)


@pytest.mark.parametrize("name", ["60E1", "60E2"])
def test_rail_head_width_is_72_mm_where_the_flanks_begin(name):
    rail = get_profile(name)
    assert rail.flank_depth_mm == pytest.approx(14.30, abs=0.01)
    assert head_width_mm(rail) == pytest.approx(72.0, abs=1e-3)
    # Above the flank tops the gauge-corner arc turns inwards, below the flanks widen 1:20.
    assert head_width_mm(rail, 14.0) < head_width_mm(rail) < head_width_mm(rail, 20.0)
    deeper = head_width_mm(rail, rail.flank_depth_mm + 10.0)
    assert deeper - head_width_mm(rail) == pytest.approx(2 * 10.0 / 20.0, abs=1e-9)


@pytest.mark.parametrize("name", ["60E1", "60E2"])
def test_crown_radius_recovered_from_sampled_points(name):
    rail = get_profile(name)
    y, z = rail.points(0.1)
    crown = np.abs(y) < CROWN_HALF_WIDTH_MM[name]
    assert _fit_circle(y[crown], z[crown]) == pytest.approx(CROWN_RADIUS_MM[name], rel=1e-6)
    # Curvature of the sampled curve: circle through each three consecutive points.
    p = np.column_stack([y[crown], z[crown]])
    a, b, c = p[:-2], p[1:-1], p[2:]
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    sides = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1) * np.linalg.norm(c - a, axis=1)
    menger = -2.0 * cross / sides            # convex (clockwise for increasing y) positive
    assert np.allclose(1.0 / menger, CROWN_RADIUS_MM[name], rtol=1e-4)
    assert rail.curvature(0.0) == pytest.approx(1.0 / CROWN_RADIUS_MM[name])


def test_gauge_corner_radii_of_rails():
    assert get_profile("60E1").curvature(-31.0) == pytest.approx(1 / 13.0)
    assert get_profile("60E2").curvature(-35.7) == pytest.approx(1 / 8.0)
    assert get_profile("60E2").curvature(-30.0) == pytest.approx(1 / 16.0)


@pytest.mark.parametrize("name", PROFILE_NAMES)
def test_points_are_spaced_by_the_step_and_pass_through_joints(name):
    profile = get_profile(name)
    y, z = profile.points(0.5)
    seg = np.hypot(np.diff(y), np.diff(z))
    assert np.all(np.diff(y) > 0)
    assert seg.max() <= 0.5 + 1e-6
    assert (y[0], y[-1]) == profile.y_range_mm
    for j in profile.joints():
        assert np.min(np.abs(y - j.y_mm)) < 1e-9


def test_profile_evaluation_outside_range_and_unknown_name():
    rail = get_profile("60E2")
    with pytest.raises(ValueError, match="y_mm"):
        rail.z(40.0)
    with pytest.raises(ValueError, match="S1002, 60E1, 60E2"):
        get_profile("UIC60")
    with pytest.raises(ValueError, match="step_mm"):
        rail.points(0.0)
    with pytest.raises(ValueError, match="rail profile"):
        head_width_mm(get_profile("S1002"))


# ---------------------------------------------------------------- custom CSV profiles

def _write(path, text):
    path.write_text(text)
    return path


def test_csv_round_trip_of_s1002(tmp_path):
    wheel = get_profile("S1002")
    y, z = wheel.points(0.25)
    lines = "y_mm,z_mm\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(y, z))
    custom = load_profile_csv(_write(tmp_path / "s1002.csv", lines), kind="wheel")
    assert custom.name == "s1002" and custom.kind == "wheel"
    yy = np.linspace(-69.0, 59.0, 2000)
    err = np.abs(custom.z(yy) - wheel.z(yy))
    # Within 10 um everywhere (the spline rounds the curvature jump at the
    # E|D joint, where the flange face meets the R13 root), 0.1 um on the tread.
    assert err.max() < 0.01
    assert err[(yy > -30.0)].max() < 1e-4
    # Curvature on the tread polynomial, away from section joints.
    for yc in (-15.0, 0.0, 10.0, 25.0):
        assert custom.curvature(yc) == pytest.approx(wheel.curvature(yc), rel=0.05, abs=2e-4)
    assert flange_height_mm(custom) == pytest.approx(28.0, abs=0.01)
    assert flange_thickness_mm(custom) == pytest.approx(32.5, abs=0.01)


def test_csv_round_trip_of_rail_with_short_header_and_descending_y(tmp_path):
    rail = get_profile("60E2")
    y, z = rail.points(0.2)
    lines = "# 60E2 head\ny,z\n" + "".join(f"{a:.6f},{b:.6f}\n" for a, b in zip(y[::-1], z[::-1]))
    custom = load_profile_csv(_write(tmp_path / "head.csv", lines), name="my rail")
    assert custom.name == "my rail" and custom.kind == "rail"
    assert 1.0 / custom.curvature(0.0) == pytest.approx(200.0, rel=0.02)
    assert head_width_mm(custom, rail.flank_depth_mm) == pytest.approx(72.0, abs=0.01)


@pytest.mark.parametrize("text, problem", [
    ("a,b\n1,2\n2,3\n3,4\n4,5\n5,6\n6,7\n", "header"),
    ("y_mm,z_mm\n1,2\n2,x\n3,4\n4,5\n5,6\n6,7\n", "not a number"),
    ("y_mm,z_mm\n1,2\n2,1_0\n3,4\n4,5\n5,6\n6,7\n", "not a number"),
    ("y_mm,z_mm\n1,2\n2,nan\n3,4\n4,5\n5,6\n6,7\n", "not finite"),
    ("y_mm,z_mm\n1,2\n2,3\n3,4\n", "at least"),
    ("y_mm,z_mm\n1,2\n2,3\n2,4\n4,5\n5,6\n6,7\n", "monotone"),
    ("y_mm,z_mm\n1,2\n3,3\n2,4\n4,5\n5,6\n6,7\n", "monotone"),
    ("y_mm,z_mm\n1,2\n2\n3,4\n4,5\n5,6\n6,7\n", "columns"),
    ("", "empty"),
])
def test_malformed_csv_names_file_and_problem(tmp_path, text, problem):
    path = _write(tmp_path / "bad_profile.csv", text)
    with pytest.raises(ValueError, match=problem) as err:
        load_profile_csv(path)
    assert "bad_profile.csv" in str(err.value)


def test_missing_csv_and_bad_kind(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_profile_csv(tmp_path / "missing.csv")
    with pytest.raises(ValueError, match="kind"):
        load_profile_csv(tmp_path / "missing.csv", kind="axle")


# ---------------------------------------------------------------- placement

def _cone_wheel(slope: float) -> Profile:
    """A coned wheel whose radius falls by `slope` per mm towards the field side."""
    return Profile("cone", "wheel", (PolynomialSection("cone", -70.0, 60.0, (0.0, -slope)),))


@pytest.mark.parametrize("eta", [-5.0, 0.0, 3.0])
def test_cone_matching_the_cant_touches_the_crown_top(eta):
    # A 1:40 cone over a rail inclined 1:40: the tangent to the crown is
    # parallel to the cone where the rail's own slope is zero, at y_rail = 0.
    placement = place_wheel_on_rail(_cone_wheel(1 / 40), "60E1", offset_mm=eta)
    assert placement.contact.y_rail_mm == pytest.approx(0.0, abs=1e-4)
    assert placement.contact.y_wheel_mm == pytest.approx(placement.contact.y_mm - eta)


def test_steeper_cone_touches_the_gauge_side_of_the_crown():
    # A 1:20 cone on a 1:40 cant: the crown slope must be tan(atan(1/20) - atan(1/40)),
    # at y_rail = -R sin(atan(1/20) - atan(1/40)) on the R300 crown of 60E1.
    placement = place_wheel_on_rail(_cone_wheel(1 / 20), "60E1", offset_mm=0.0)
    expected = -300.0 * math.sin(math.atan(1 / 20) - math.atan(1 / 40))
    assert placement.contact.y_rail_mm == pytest.approx(expected, abs=1e-4)
    assert placement.contact.contact_angle_rad == pytest.approx(math.atan(1 / 20), abs=1e-8)


@pytest.mark.parametrize("rail", ["60E1", "60E2"])
def test_positive_offset_moves_contact_towards_flange_and_gauge_corner(rail):
    etas = np.arange(-7.0, 2.01, 0.5)
    contacts = [place_wheel_on_rail("S1002", rail, offset_mm=e).contact for e in etas]
    y_wheel = np.array([c.y_wheel_mm for c in contacts])
    y_rail = np.array([c.y_rail_mm for c in contacts])
    assert np.all(np.diff(y_wheel) < 0) and np.all(np.diff(y_rail) < 0)
    assert y_rail[-1] < -10.0 < y_rail[0]


def test_contact_at_zero_offset_is_on_the_60e2_crown():
    at_zero = place_wheel_on_rail("S1002", "60E2", offset_mm=0.0).contact
    assert abs(at_zero.y_rail_mm) < CROWN_HALF_WIDTH_MM["60E2"]
    assert at_zero.rail_curvature_per_mm == pytest.approx(1 / 200.0)
    # The tread (1:30 at the tape circle) is steeper than the 1:40 cant, so the
    # contact reaches the crown centre when the tape circle is on its field side.
    centred = place_wheel_on_rail("S1002", "60E2", offset_mm=-3.0).contact
    assert abs(centred.y_rail_mm) < 0.5


def test_second_contact_near_the_flange_for_large_offset():
    single = place_wheel_on_rail("S1002", "60E2", offset_mm=-3.0)
    assert len(single.contact_points) == 1
    two = place_wheel_on_rail("S1002", "60E2", offset_mm=3.5, tolerance_mm=0.1)
    assert len(two.contact_points) >= 2
    tread, flange = two.contact_points[0], two.contact_points[1]
    assert tread.separation_mm == 0.0 and 0.0 < flange.separation_mm <= 0.1
    assert flange.y_wheel_mm < -26.0 < tread.y_wheel_mm   # S1002 flange root starts at -26 mm
    # Further out the flange face (70 deg, S1002 section E) carries the contact.
    flange_contact = place_wheel_on_rail("S1002", "60E2", offset_mm=4.5).contact
    assert math.degrees(flange_contact.contact_angle_rad) == pytest.approx(70.0, abs=0.01)


def test_separation_is_nonnegative_and_zero_at_contact():
    placement = place_wheel_on_rail("S1002", "60E2", offset_mm=-3.0)
    y = np.linspace(*placement.y_range_mm, 20001)
    sep = placement.separation(y)
    assert sep.min() >= -1e-9
    assert placement.separation(placement.contact.y_mm) == pytest.approx(0.0, abs=1e-9)
    assert placement.rail_height(placement.contact.y_mm) == pytest.approx(placement.contact.z_mm)


def test_rail_height_matches_rotated_sample_points():
    # Second method for the inclined rail: rotate sampled points forwards and
    # compare with the inverse mapping used by rail_height.
    placement = place_wheel_on_rail("S1002", "60E1", offset_mm=-3.0)
    y, z = placement.rail_points(0.5)
    assert np.max(np.abs(placement.rail_height(y) - z)) < 1e-9
    assert placement.rail_y(y[0]) == pytest.approx(get_profile("60E1").y_range_mm[0])


def test_rolling_radius_and_3d_gap():
    placement = place_wheel_on_rail("S1002", "60E2", offset_mm=-3.0)
    c = placement.contact
    assert c.rolling_radius_mm == pytest.approx(460.0 + get_profile("S1002").z(c.y_wheel_mm))
    assert placement.rolling_radius(-3.0) == pytest.approx(460.0)   # the tape circle
    y = np.linspace(c.y_mm - 5, c.y_mm + 5, 11)
    assert np.allclose(placement.gap(0.0, y), placement.separation(y), atol=1e-12)
    x = np.array([-8.0, -2.0, 2.0, 8.0])
    g = placement.gap(x, c.y_mm)
    assert np.allclose(g, x**2 / (2 * c.rolling_radius_mm), rtol=1e-3)
    grid_x, grid_y = np.meshgrid(np.linspace(-10, 10, 5), y)
    assert placement.gap(grid_x, grid_y).shape == grid_x.shape


def test_placement_bad_input():
    lo, hi = offset_range_mm(get_profile("S1002"), get_profile("60E2"))
    with pytest.raises(ValueError, match=r"offset_mm must lie in \[") as err:
        place_wheel_on_rail("S1002", "60E2", offset_mm=hi + 1.0)
    assert f"{lo:.2f}" in str(err.value)
    with pytest.raises(ValueError, match="S1002, 60E1, 60E2"):
        place_wheel_on_rail("S1002", "UIC60")
    with pytest.raises(ValueError, match="wheel"):
        place_wheel_on_rail("60E1", "60E2")
    with pytest.raises(ValueError, match="rail_inclination"):
        place_wheel_on_rail(offset_mm=0.0, rail_inclination=-0.1)
    with pytest.raises(ValueError, match="nominal_radius_mm"):
        place_wheel_on_rail(nominal_radius_mm=0.0)
    placement = place_wheel_on_rail()
    with pytest.raises(ValueError, match="y_mm"):
        placement.separation(50.0)


# ---------------------------------------------------------------- CLI

def test_cli_csv(capsys):
    assert main(["profile", "S1002", "--step-mm", "0.5", "--csv"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == "y_mm,z_mm"
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    assert data[0, 0] == pytest.approx(-70.0) and data[-1, 0] == pytest.approx(60.0)
    assert data[:, 1].max() == pytest.approx(28.0, abs=1e-3)


def test_cli_json_out_and_plot(tmp_path, capsys):
    import json

    out, png = tmp_path / "rail.csv", tmp_path / "rail.png"
    assert main(["profile", "60E2", "--json", "--out", str(out), "--plot", str(png)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["name"] == "60E2" and summary["kind"] == "rail"
    assert summary["dimensions"]["head_width_mm"] == pytest.approx(72.0, abs=1e-3)
    assert summary["n_points"] == len(out.read_text().splitlines()) - 1
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["profile", "S1002", "--json"]) == 0
    dims = json.loads(capsys.readouterr().out)["dimensions"]
    assert dims["flange_height_mm"] == pytest.approx(28.0, abs=1e-6)
    assert dims["flange_thickness_mm"] == pytest.approx(32.5, abs=1e-3)


def test_cli_unknown_profile_exits_2(capsys):
    assert main(["profile", "UIC60"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "S1002, 60E1, 60E2" in err[0]
    with pytest.raises(SystemExit) as refused:  # refused by the parser, with the bound it states in --help
        main(["profile", "60E1", "--step-mm", "-1"])
    assert refused.value.code == 2 and "--step-mm" in capsys.readouterr().err


def test_a_dense_measured_profile_is_averaged_in_bins_before_its_spline(tmp_path, monkeypatch):
    """10^6 points of an optical profile took 20 s and ended 'ill-posed' in the spline's cross-validation;
    above MAX_PROFILE_POINTS the points are averaged in equal-width bins, and the curve is still the curve."""
    import filmcal.wheelrail.profiles as profiles

    monkeypatch.setattr(profiles, "MAX_PROFILE_POINTS", 2000)
    y = np.linspace(-30.0, 30.0, 20_001)
    z = y**2 / (2 * 300.0)  # a 300 mm circle's parabola (closed form)
    path = tmp_path / "dense.csv"
    path.write_text("y_mm,z_mm\n" + "\n".join(f"{a:.6f},{b:.7f}" for a, b in zip(y, z)) + "\n")
    profile = profiles.load_profile_csv(path, kind="rail")
    assert "2000 bin means of 20001 points" in profile.source
    t = np.linspace(-29.0, 29.0, 301)
    assert np.max(np.abs(profile.z(t) - t**2 / 600.0)) < 2e-5  # bin means of a parabola: a 0.03 um shift


def _arc_rail_csv(path, radius_mm: float, half_width_mm: float, bom: bool = False, scale: float = 1.0):
    """A partial rail head: a circular crown of `radius_mm` over +-`half_width_mm`, points in mm x `scale`."""
    y = np.linspace(-half_width_mm, half_width_mm, 141)
    z = np.sqrt(radius_mm**2 - y**2) - radius_mm if math.isfinite(radius_mm) else 0.0 * y
    text = ("\ufeff" if bom else "") + "y_mm,z_mm\r\n" + "".join(
        f"{a * scale:.9g},{b * scale:.9g}\r\n" for a, b in zip(y, z))
    return _write(path, text)


def test_json_summary_of_a_partial_rail_head_says_which_dimensions_it_does_not_reach(tmp_path, capsys):
    """A measured crown 70 mm wide and 2 mm deep was refused ('depth_mm must lie in (0, 2.04)'): the
    summary asked for the head width 14 mm below the crown top. Now that width is null with the reason,
    and the crown radius is the arc's (R300 drawn into the file)."""
    import json

    path = _arc_rail_csv(tmp_path / "crown.csv", 300.0, 35.0)
    assert main(["profile", str(path), "--json"]) == 0
    dims = json.loads(capsys.readouterr().out)["dimensions"]
    assert dims["head_width_mm"] is None and dims["head_width_at_gauge_depth_mm"] is None
    assert dims["crown_radius_mm"] == pytest.approx(300.0, rel=1e-3)
    sagitta = 300.0 - math.sqrt(300.0**2 - 35.0**2)  # 2.049 mm: the depth the crown's ends reach
    assert len(dims["not_reached"]) == 1 and f"{sagitta:.3g} mm below" in dims["not_reached"][0]
    flat = _arc_rail_csv(tmp_path / "flat.csv", math.inf, 35.0)
    assert main(["profile", str(flat), "--json"]) == 0
    dims = json.loads(capsys.readouterr().out)["dimensions"]
    assert dims["crown_radius_mm"] is None and any("straight" in r for r in dims["not_reached"])


def test_a_profile_with_a_byte_order_mark_and_crlf_reads_like_one_without(tmp_path):
    plain = load_profile_csv(_arc_rail_csv(tmp_path / "plain.csv", 300.0, 35.0))
    marked = load_profile_csv(_arc_rail_csv(tmp_path / "marked.csv", 300.0, 35.0, bom=True))
    yy = np.linspace(-30.0, 30.0, 61)
    np.testing.assert_array_equal(marked.z(yy), plain.z(yy))


def test_a_profile_in_metres_is_refused_with_the_units(tmp_path, capsys):
    """The same crown written in metres spans 0.07 'mm' and was read as a 70-um wide rail."""
    path = _arc_rail_csv(tmp_path / "metres.csv", 300.0, 35.0, scale=1e-3)
    assert main(["profile", str(path), "--json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "0.07 mm across" in err[0] and "not m" in err[0], err


@pytest.mark.parametrize("rail", ["60E1", "60E2"])
def test_a_cant_of_one_in_twenty_cuts_the_field_flank_it_turns_vertical(rail):
    """The heads' flanks lean 1:20 from the vertical (87.14 deg), so a cant of 1/20 turns one of them vertical and
    the inclined profile was refused as not single-valued, though `--rail-inclination` offers 1/20. The flank is
    cut where it stands steeper than 89 deg, far below any wheel contact: a cropped profile evaluates as the whole
    one inside its range, the first contact is where the whole rail puts it, and S1002 solves there."""
    from filmcal.wheelrail import solve_wheel_rail
    from filmcal.wheelrail.profiles import get_profile

    whole = get_profile(rail)
    assert math.degrees(math.atan(float(np.max(np.abs(whole.slope(whole.points(0.1)[0])))))) > 87.0
    lo, hi = whole.y_range_mm
    part = whole.cropped(lo + 5.0, hi - 5.0)
    y = np.linspace(lo + 5.0, hi - 5.0, 301)
    assert np.array_equal(part.z(y), whole.z(y)) and part.y_range_mm == (lo + 5.0, hi - 5.0)
    steep = place_wheel_on_rail(rail=rail, offset_mm=-3.0, rail_inclination=0.05)
    assert steep.rail.y_range_mm != whole.y_range_mm  # cut
    gentle = place_wheel_on_rail(rail=rail, offset_mm=-3.0, rail_inclination=1 / 40)
    assert gentle.rail.y_range_mm == whole.y_range_mm  # the default cant keeps the rail whole
    # the same first contact as on a rail cut by hand well below the head, at a cant both accept
    cut = whole.cropped(lo + 8.0, hi - 8.0)
    a = place_wheel_on_rail(rail=whole, offset_mm=-3.0, rail_inclination=1 / 40).contact_points[0]
    b = place_wheel_on_rail(rail=cut, offset_mm=-3.0, rail_inclination=1 / 40).contact_points[0]
    # the lift is flat at its top: its position is found to ~1e-5 mm, its height to rounding
    assert a.y_mm == pytest.approx(b.y_mm, abs=1e-4) and a.separation_mm == pytest.approx(b.separation_mm, abs=1e-9)
    for eta in (-3.0, 0.0, 2.0):
        assert solve_wheel_rail(eta, 100e3, rail=rail, rail_inclination=0.05).area_mm2 > 50.0
