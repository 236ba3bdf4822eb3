"""Posterior correction curves against direct wheel-rail solves."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.contact.film import FilmModel
from filmcal.correction import correction_curves
from filmcal.films import get_film
from filmcal.wheelrail import FilmLayer, solve_wheel_rail

HS_EDGE = FilmModel(get_film("HS"), "edge", "small")


def test_bands_match_direct_solves_at_their_quantiles():
    rng = np.random.default_rng(1)
    samples = np.exp(rng.normal(np.log(2800.0), 0.04, 3000))
    c = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    a0 = solve_wheel_rail(-4.0, 50e3).area_mm2
    assert c.area_no_film_mm2[0, 0] == pytest.approx(a0, rel=1e-6)  # the sweep solves to a tolerance of 1e-6
    # the film area is monotone in E: the band's ends are the film areas at the 95 % / 5 % quantiles of E, the
    # area the calibrated film records (the solve's plus the transfer term's shift; its spread, about 1e-3 of
    # the area, moves these quantiles by far less than the tolerance)
    for q, k in ((0.05, 1), (0.95, 0)):
        e = float(np.quantile(samples, q))
        result = solve_wheel_rail(-4.0, 50e3, film=FilmLayer(e, 0.33, 0.09))
        direct = result.area_mm2 + HS_EDGE.transfer_term(e, result).shift_mm2
        # within twice the noise of one solve's area: counted cells scatter by up to 1e-3 of the area from
        # modulus to modulus (residuals of a least-squares quadratic through 25 solves over this range)
        assert a0 + c.delta_area_ci90_mm2[0, 0, k] == pytest.approx(direct, rel=2e-3)
    assert c.ratio_ci90[0, 0, 0] < c.ratio_median[0, 0] < c.ratio_ci90[0, 0, 1] < 1.0
    assert c.interpolation_error_rel[0, 0] < 2e-3


def test_bad_samples():
    with pytest.raises(ValueError, match="modulus_samples_mpa"):
        correction_curves([(HS_EDGE, [2800.0, -1.0], 1.0)], [-4.0], [50e3])
    with pytest.raises(ValueError, match="weights"):
        correction_curves([(HS_EDGE, [2800.0], -1.0)], [-4.0], [50e3])


def test_a_mixture_band_spans_the_models_it_pools():
    """Two models that read the same contact differently (edge, activation contour), equal weights: the
    pooled 90 % band reaches from one model's median to the other's (a property of a 50/50 mixture of two
    well-separated, narrow components)."""
    rng = np.random.default_rng(2)
    samples = np.exp(rng.normal(np.log(2800.0), 0.02, 2000))
    activation = FilmModel(get_film("HS"), "activation", "small")
    edge_only = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    act_only = correction_curves([(activation, samples, 1.0)], [-4.0], [50e3])
    mixed = correction_curves([(HS_EDGE, samples, 1.0), (activation, samples, 1.0)], [-4.0], [50e3])
    # the activation contour lies inside the contact edge: a smaller recorded area
    assert act_only.area_film_median_mm2[0, 0] < edge_only.area_film_median_mm2[0, 0]
    lo, hi = mixed.delta_area_ci90_mm2[0, 0]
    assert lo <= act_only.delta_area_median_mm2[0, 0] and edge_only.delta_area_median_mm2[0, 0] <= hi
    assert hi - lo > edge_only.delta_area_ci90_mm2[0, 0, 1] - edge_only.delta_area_ci90_mm2[0, 0, 0]


def test_rough_curves_pair_each_sample_with_one_draw_of_the_growths():
    """Rough curves are the smooth samples times one draw's growths each: with a single draw the rough
    median and band are the smooth ones scaled exactly (a monotone map of the same samples), the area
    without film is A0 g_0, and the roughness adds no variance; with two draws the factor's band widens and
    the Monte-Carlo error is the draws' standard error."""
    from filmcal.correction.roughness import RoughGrowth

    rng = np.random.default_rng(3)
    samples = np.exp(rng.normal(np.log(2800.0), 0.04, 2000))
    cell = (50e3, -4.0)
    one = {cell: {HS_EDGE.label: RoughGrowth(np.array([1.10]), np.array([1.20]), np.array([1.0]))}}
    g0, gf = np.array([1.20, 1.10]), np.array([1.05, 1.10])
    two = {cell: {HS_EDGE.label: RoughGrowth(gf, g0, np.array([0.5, 0.5]))}}
    c = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3], rough=[one, two])
    r1, r2 = c.rough
    assert r1.area_no_film_mm2[0, 0] == pytest.approx(1.20 * c.area_no_film_mm2[0, 0], rel=1e-12)
    assert r1.area_film_median_mm2[0, 0] == pytest.approx(1.10 * c.area_film_median_mm2[0, 0], rel=1e-12)
    assert r1.ratio_median[0, 0] == pytest.approx(c.ratio_median[0, 0] * 1.20 / 1.10, rel=1e-12)
    np.testing.assert_allclose(r1.ratio_ci90[0, 0], c.ratio_ci90[0, 0] * 1.20 / 1.10, rtol=1e-12)
    # one draw: no spread to estimate the Monte-Carlo error from (it read 0.000, as if exact)
    assert r1.roughness_share[0, 0] < 1e-9 and np.isnan(r1.roughness_mc_error_rel[0, 0])
    # two draws, factors 1.20/1.05 and 1.0: the band reaches both scaled smooth medians
    assert r2.area_no_film_mm2[0, 0] == pytest.approx(1.15 * c.area_no_film_mm2[0, 0], rel=1e-12)
    lo, hi = r2.ratio_ci90[0, 0]
    assert lo < c.ratio_median[0, 0] * 1.0 * 1.01 and hi > c.ratio_median[0, 0] * (1.20 / 1.05) * 0.99
    assert r2.roughness_share[0, 0] > 0.9
    h = g0 / gf
    assert r2.roughness_mc_error_rel[0, 0] == pytest.approx(np.std(h) / np.sqrt(2) / np.mean(h), rel=1e-9)
    # the smooth curves are those without rough configurations, to the bit
    alone = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    assert alone.ratio_median[0, 0] == c.ratio_median[0, 0] and np.all(alone.ratio_ci90 == c.ratio_ci90)


def test_growth_task_matches_direct_solves():
    """One cell's growths from `growth_task` (smooth solves shared by the draws, warm starts, the sweep's
    tolerance) against direct, cold solves of each draw at the default tolerance: the film's rough reading
    over its smooth one, and the rough bodies' nominal area without film over the smooth one."""
    from filmcal.contact.reading import nominal_area_mm2
    from filmcal.contact.rough_imprint import load_roughness_inputs, rough_recorded_area_mm2
    from filmcal.correction import growth_task
    from filmcal.correction.roughness import draw_laws

    draws = list(dict.fromkeys(load_roughness_inputs()))[:2]
    film, e = HS_EDGE.film, 2800.0
    laws = {d: draw_laws(d, {"HS": (film, e)}, wheel=1.5) for d in draws}
    got = growth_task([("HS", HS_EDGE, e)], draws, laws, -4.0, 50e3, {})

    def level(result):
        return nominal_area_mm2(result.contact.grid.x_mm, result.contact.grid.y_mm, result.contact.pressure_mpa)

    bare = solve_wheel_rail(-4.0, 50e3)
    layer = FilmLayer(e, film.poisson, film.thickness_mm)
    smooth = solve_wheel_rail(-4.0, 50e3, film=layer)
    for d in draws:
        bodies = d.bodies(1.5)
        film_law = bodies.film_law(e, film.poisson, film.thickness_mm)
        solver_film, solver_law, _ = HS_EDGE.interface(e, film_law)
        rough = solve_wheel_rail(-4.0, 50e3, film=solver_film, roughness=solver_law)
        g_f = rough_recorded_area_mm2(HS_EDGE, rough, film_law, d.reading_level) / smooth.area_mm2
        g_0 = level(solve_wheel_rail(-4.0, 50e3, roughness=bodies.steel_law())) / level(bare)
        assert got[d][0] == pytest.approx(g_0, rel=1e-4) and got[d][1][0] == pytest.approx(g_f, rel=1e-4)
        assert got[d][0] > 1.02 and got[d][1][0] > 1.0


def test_zero_roughness_gives_the_smooth_curves_to_the_last_digit():
    from filmcal.contact.rough_imprint import load_roughness_inputs
    from filmcal.correction import RoughConfiguration, curve_table

    samples = np.exp(np.random.default_rng(4).normal(np.log(2800.0), 0.04, 500))
    flat = RoughConfiguration(0.0, None, tuple(load_roughness_inputs()[:2]))
    rows = curve_table("HS", [(HS_EDGE, samples, 1.0)], [-4.0], [50.0], [flat], workers=1)
    assert len(rows) == 2 and rows[0][1] == "smooth"
    assert rows[0][2:14] == rows[1][2:14] and rows[1][14] == 0.0


def test_a_cell_the_model_cannot_solve_is_named_as_bad_input():
    """An MS film at eta +4 mm and 20 kN spreads the flange contact past the profiles' ends: the curves said
    "internal error" (exit 70, a RuntimeError of the worker pool); the cell is now an InputError that names
    it, with or without rough bodies."""
    from filmcal._errors import InputError
    from filmcal.contact.rough_imprint import load_roughness_inputs
    from filmcal.correction import RoughConfiguration, curve_table

    ms = FilmModel(get_film("MS"), "edge", "small")
    samples = np.full(50, 540.0)
    for rough in ([], [RoughConfiguration(1.5, None, tuple(load_roughness_inputs()[:1]))]):
        with pytest.raises(InputError, match=r"the cell eta \+4 mm, 20 kN cannot be solved: .*end of the wheel"):
            curve_table("MS", [(ms, samples, 1.0)], [-4.0, 4.0], [20.0], rough, workers=1)


def test_curve_rows_label_rough_bodies_by_their_measured_ra():
    from filmcal.contact.rough_imprint import representative_roughness_inputs
    from filmcal.correction.curves import wheel_label

    bodies = representative_roughness_inputs().bodies(None, 1.5)
    assert wheel_label(bodies) == f"rough rail Ra {bodies.rail.ra_um:.3g} um"
    assert wheel_label(1.5) == "rough Ra 1.5 um" and wheel_label(None) == "smooth"


def test_curves_refuses_an_ra_and_a_map_for_one_body(tmp_path):
    import subprocess
    import sys

    (tmp_path / "st").mkdir()
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--study-dir",
                        str(tmp_path / "st"), "--rail-roughness-ra-um", "1.5", "--rail-roughness-map",
                        str(tmp_path / "none.x3p")], capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1


def test_curves_beyond_the_elastic_limit_or_the_transfer_say_so_as_correct_does(quick_study):
    """`curves --forces-kn 2000` printed its rows at a peak of 3.4 GPa without a word; `correct` warned. Hertz's
    peak pressure of the S1002/60E2 contact (1.1 GPa at 100 kN) grows as F^(1/3): 2000 kN is far beyond the
    limit, 100 kN below it. Its size too is beyond what the film's transfer was fitted on, as is 2 kN's."""
    import json
    import subprocess
    import sys

    study, _, _ = quick_study
    cli = [sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--study-dir", str(study), "--offsets-mm=-3",
           "--progress", "quiet", "--json", "--forces-kn"]
    p = subprocess.run(cli + ["2,100,2000"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    answer = json.loads(p.stdout)
    elastic, transfer = answer["warnings"]
    assert "elastic limit" in elastic and "at 1 of 3 (load, offset) cells" in elastic
    # the film's transfer was fitted on Hertz radii of 2.06-11.7 mm: at 2 kN the patch is about 1.8 mm, at 2000 kN
    # about 18 mm (F^(1/3) from 6.6 mm at 100 kN), as `correct` warns
    assert "transfer" in transfer and "extrapolated at 2 of 3 (load, offset) cells" in transfer
    assert "at 2 kN, eta -3 mm: the contact without film is smaller" in transfer
    assert p.stderr.strip().splitlines() == [f"filmcal curves: warning: {w}" for w in answer["warnings"]]
    p = subprocess.run(cli + ["100"], capture_output=True, text=True)
    assert p.returncode == 0 and p.stderr == "" and "warnings" not in json.loads(p.stdout)


def test_curves_takes_the_offsets_correct_takes(tmp_path):
    """One bound for eta everywhere (`OFFSET_MM_BOUNDS`): curves refused +12 mm, which correct, serve and
    wheelrail solve; beyond the bound it is refused before the study is opened."""
    import subprocess
    import sys

    from filmcal._validation import OFFSET_MM_BOUNDS

    cli = [sys.executable, "-m", "filmcal.cli", "curves", "--study-dir", str(tmp_path / "none"), "--film", "HS"]
    p = subprocess.run(cli + [f"--offsets-mm={OFFSET_MM_BOUNDS[0] - 1:g}"], capture_output=True, text=True)
    assert p.returncode == 2 and "--offsets-mm must lie in [-60, 60] mm" in p.stderr, p.stderr
    p = subprocess.run(cli + ["--offsets-mm=12"], capture_output=True, text=True)
    assert p.returncode == 2 and "must lie in" not in p.stderr and "does not exist" in p.stderr, p.stderr


@pytest.mark.slow
def test_rough_curves_keep_each_law_as_it_solves_it_and_read_the_pipelines(quick_study, tmp_path, capsys,
                                                                            rough_law_solves):
    """`filmcal curves` on rough bodies solved its boundary-element laws in a temporary folder: Ctrl-C lost them,
    and the pipeline's own Ra was solved again. Each law is now read from the study or kept there as it is solved
    (as `filmcal correct` keeps them): an interrupted run solves only the missing laws again and its rows equal
    an uninterrupted run's; the pipeline's laws (wheel Ra 1.5 um, its draws) are read, not solved."""
    import json
    import shutil

    from filmcal import cli

    studies = {}
    for name in ("interrupted", "whole"):
        studies[name] = tmp_path / name
        shutil.copytree(quick_study[0], studies[name])
    solved = rough_law_solves

    said = []

    def curves(study, ra_um, stop_at=None):
        solved.stop_at = stop_at
        status = cli.main(["curves", "--film", "HS", "--study-dir", str(study), "--offsets-mm=-3", "--forces-kn",
                           "100", "--wheel-roughness-ra-um", str(ra_um), "--roughness-draws", "2", "--workers", "1",
                           "--json"])
        out, err = capsys.readouterr()
        said.append(err)
        return status, (json.loads(out)["rows"] if status == 0 else None)

    status, _ = curves(studies["whole"], 1.5)
    assert status == 0 and solved == [], "the pipeline's laws were solved again"
    status, _ = curves(studies["interrupted"], 2.0, stop_at=2)  # the first draw's two laws, then Ctrl-C
    assert status == 130
    kept = {k: v for k, v in json.loads((studies["interrupted"] / "study.json").read_text())["caches"].items()
            if v["kind"] == "rough-law"}
    assert len(kept) == 2 and all((studies["interrupted"] / k).is_file() for k in kept)
    solved.clear()
    status, resumed = curves(studies["interrupted"], 2.0)
    assert status == 0 and solved == ["film_law", "steel_law"]  # the second draw's only
    assert "rough Ra 2 um: 2 roughness laws (boundary elements, seconds to minutes each) to solve, 2 read from " \
           "the study" in said[-1], said[-1]
    status, whole = curves(studies["whole"], 2.0)
    assert status == 0 and resumed == whole


def test_the_draws_of_a_measured_map_share_its_law_without_film(rough_law_solves, tmp_path):
    """A measured map is the same micro surface in every draw of the roughness inputs, and the law without film
    (steel on steel) depends on nothing else (`rough_law_spec`): its minutes-long solve was repeated per draw.
    It is solved once; the laws against the film differ with each draw's film hardness."""
    from filmcal.contact.rough_imprint import load_roughness_inputs
    from filmcal.contact.roughness import RoughSurface
    from filmcal.correction.curves import RoughConfiguration, rough_law_files

    draws = tuple(load_roughness_inputs()[:2])
    assert draws[0].film_hardness_mpa != draws[1].film_hardness_mpa
    surface = RoughSurface.synthetic(ra_um=1.0, n=64, seed=5)
    laws = rough_law_files(RoughConfiguration(surface, None, draws), {"HS": (get_film("HS"), 2500.0)}, 1,
                           tmp_path / "laws")
    assert sorted(rough_law_solves) == ["film_law", "film_law", "steel_law"]
    assert laws[draws[0]][None] == laws[draws[1]][None] and laws[draws[0]]["HS"] != laws[draws[1]]["HS"]


def test_the_transfer_note_names_the_cells_where_the_film_transfer_is_extrapolated():
    """The note `filmcal curves` and the pipeline's curves stage give, from the rows' contacts without film: a
    0.09 mm film on patches of 6 mm equivalent radius says nothing; a patch of 1.5 mm (below the 2.06 mm of the
    fit's smallest sphere-on-flat contact) is named, and a 0.3 mm film (beyond the fitted 0.04-0.25 mm) at every
    cell."""
    from dataclasses import replace

    from filmcal.correction import CURVE_COLUMNS
    from filmcal.correction.curves import transfer_note

    def row(force, offset, radius_mm):
        r = [0.0] * len(CURVE_COLUMNS)
        r[:4] = ["HS", "smooth", force, offset]
        r[CURVE_COLUMNS.index("area_no_film_mm2")] = np.pi * radius_mm**2
        r[CURVE_COLUMNS.index("max_pressure_no_film_mpa")] = 900.0
        return r

    hs = get_film("HS")
    samples = np.full(50, 2500.0)
    usual = [row(100.0, 0.0, 6.0), row(100.0, 0.0, 6.0), row(50.0, -3.0, 6.0)]  # a cell's smooth and rough rows
    assert transfer_note(usual, [(FilmModel(hs, "edge", "small"), samples, 1.0)]) is None
    note = transfer_note(usual + [row(2.0, -3.0, 1.5)], [(FilmModel(hs, "activation", "small"), samples, 1.0)])
    assert "at 1 of 3 (load, offset) cells (at 2 kN, eta -3 mm: the contact without film is smaller" in note
    assert transfer_note(usual, [(FilmModel(replace(hs, thickness_mm=0.12), "edge", "small"), samples, 1.0)]) is None
    thick = FilmModel(replace(hs, thickness_mm=0.3), "edge", "small")
    note = transfer_note(usual, [(thick, samples, 1.0)])
    assert "at 2 of 2 (load, offset) cells" in note and "0.3 mm thick" in note
