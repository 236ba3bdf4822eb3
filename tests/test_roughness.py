"""Rough steel on the film: surfaces, the periodic BEM and the pressure-closure law."""
from __future__ import annotations

import math

import numpy as np
import pytest

from filmcal.contact.roughness import (PET_HARDNESS_MPA, RoughSurface, bearing_area_closure_mm,
                                       layer_compliance_factor, persson_contact_fraction,
                                       rough_contact_law, solve_periodic_contact)
from filmcal.elastic import oedometric_modulus_mpa
from filmcal.wheelrail.halfspace import sphere_on_flat_contact
from filmcal.contact.laws import FilmLayer, TabularLaw

RIGID = 1e15  # a rigid rough body, for the analytic cases


def test_layer_kernel_limits():
    """Thick layer: a half-space; thin layer: the film's oedometric compression t/M."""
    nu = 0.33
    assert layer_compliance_factor(np.array([30.0, 50.0]), nu) == pytest.approx([1.0, 1.0])
    assert layer_compliance_factor(np.array([8.0]), nu)[0] == pytest.approx(1.0, abs=1e-4)
    e, t = 2739.0, 90.0  # MPa, um
    q = np.array([1e-5, 1e-4]) / t
    closure_per_mpa = 2.0 * layer_compliance_factor(q * t, nu) * (1 - nu ** 2) / (e * q)
    assert closure_per_mpa == pytest.approx(t / oedometric_modulus_mpa(e, nu), rel=1e-4)
    # monotone between the limits
    k = np.geomspace(1e-3, 10.0, 200)
    assert np.all(np.diff(layer_compliance_factor(k, nu)) > 0)


@pytest.mark.parametrize("qt", [0.3, 1.0, 3.0])
def test_layer_kernel_against_plane_strain_fe(qt):
    """Second method: a plane-strain FE model of the film (bonded at its base, cosine
    pressure on top, symmetry at the quarter-waves) moves its top by the kernel's amount."""
    from skfem import (Basis, ElementQuad2, ElementVector, FacetBasis, LinearForm, MeshQuad, asm,
                       condense, solve)
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    e, nu, t = 2739.0, 0.33, 90.0
    q = qt / t
    half = math.pi / q
    mesh = MeshQuad.init_tensor(np.linspace(0, half, 33), np.linspace(0, t, 17)).with_boundaries({
        "top": lambda x: np.isclose(x[1], t), "bottom": lambda x: np.isclose(x[1], 0),
        "left": lambda x: np.isclose(x[0], 0), "right": lambda x: np.isclose(x[0], half)})
    element = ElementVector(ElementQuad2())
    basis = Basis(mesh, element)
    stiffness = asm(linear_elasticity(*lame_parameters(e, nu)), basis)

    @LinearForm
    def pressure(v, w):
        return -np.cos(q * w.x[0]) * v[1]

    force = asm(pressure, FacetBasis(mesh, element, facets="top"))
    fixed = np.concatenate([basis.get_dofs("bottom").all(), basis.get_dofs("left").nodal["u^1"],
                            basis.get_dofs("right").nodal["u^1"]])
    u = solve(*condense(stiffness, force, D=fixed))
    node = np.nonzero(np.isclose(mesh.p[0], 0) & np.isclose(mesh.p[1], t))[0][0]
    closure = -u[basis.nodal_dofs[1, node]]
    kernel = 2 * layer_compliance_factor(np.array([qt]), nu)[0] * (1 - nu ** 2) / (e * q)
    assert closure == pytest.approx(kernel, rel=0.01)


def _wavy(n=256, wavelength_um=100.0, amplitude_um=1.0) -> RoughSurface:
    x = (np.arange(n) + 0.5) * wavelength_um / n
    h = amplitude_um * np.cos(2 * math.pi * x / wavelength_um)[:, None] * np.ones((1, 8))
    return RoughSurface(h, wavelength_um / n, "wavy")


def test_wavy_surface_partial_contact_width_is_johnson():
    """Rigid wavy surface on an elastic half-space (Westergaard; Johnson 1985, 13.2):
    p_mean = p* sin^2(pi a / lambda), p* = pi E' Delta / lambda."""
    e, nu = 2739.0, 0.33
    surf = _wavy()
    p_star = math.pi * e / (1 - nu ** 2) * 1.0 / 100.0
    loads = p_star * np.array([0.05, 0.2, 0.5])
    steps = solve_periodic_contact(surf, loads, film_modulus_mpa=e, film_poisson=nu,
                                   film_thickness_mm=1e6, hardness_mpa=math.inf,
                                   steel_modulus_mpa=RIGID)
    for load, step in zip(loads, steps):
        expected = (2 / math.pi) * math.asin(math.sqrt(load / p_star))
        assert step.converged
        assert step.contact_fraction == pytest.approx(expected, abs=2.5 / 256)


def test_wavy_surface_full_contact_pressure_is_the_cosine():
    """Above p*, full contact: p = p_mean + p* cos(2 pi x / lambda) exactly."""
    e, nu = 2739.0, 0.33
    surf = _wavy()
    p_star = math.pi * e / (1 - nu ** 2) / 100.0
    step = solve_periodic_contact(surf, [1.5 * p_star], film_modulus_mpa=e, film_poisson=nu,
                                  film_thickness_mm=1e6, hardness_mpa=math.inf,
                                  steel_modulus_mpa=RIGID)[0]
    x = (np.arange(256) + 0.5) / 256
    expected = 1.5 * p_star + p_star * np.cos(2 * math.pi * x)
    assert step.pressure_mpa[:, 3] == pytest.approx(expected, rel=2e-3)


def test_synthetic_surface_is_seeded_and_scaled():
    a = RoughSurface.synthetic(ra_um=1.5, seed=3, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    b = RoughSurface.synthetic(ra_um=1.5, seed=3, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    c = RoughSurface.synthetic(ra_um=1.5, seed=4, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    assert np.array_equal(a.heights_um, b.heights_um) and a.fingerprint() == b.fingerprint()
    assert not np.array_equal(a.heights_um, c.heights_um) and a.fingerprint() != c.fingerprint()
    # the key is kept once made (a map's draws ask it per film): safe as the heights cannot change under it
    assert a.fingerprint() is a.fingerprint() and not a.heights_um.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        a.heights_um[0, 0] += 1.0
    assert RoughSurface(a.heights_um, a.pixel_um * 2).fingerprint() != a.fingerprint()
    assert a.rms_um == pytest.approx(math.sqrt(math.pi / 2) * 1.5, rel=1e-12)
    assert a.ra_um == pytest.approx(1.5, rel=0.08)  # Gaussian heights: Ra = sqrt(2/pi) rms
    s = RoughSurface.synthetic(rms_um=1.0, rms_slope=0.3, n=128, size_um=100.0,
                               rolloff_wavelength_um=25.0, seed=1)
    assert s.rms_slope == pytest.approx(0.3, rel=1e-3)
    # the spectral slope against finite differences (second method)
    gx = np.diff(s.heights_um, axis=0, append=s.heights_um[:1]) / s.pixel_um
    gy = np.diff(s.heights_um, axis=1, append=s.heights_um[:, :1]) / s.pixel_um
    assert math.sqrt(np.mean(gx ** 2 + gy ** 2)) == pytest.approx(s.rms_slope, rel=0.15)


def test_fully_plastic_limit_is_the_bearing_area_curve():
    """H far below E* h': every spot carries H; A/A0 = p/H and the closure is the
    Abbott-Firestone truncation of the heights."""
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    hardness = 1.0
    loads = np.array([0.05, 0.2, 0.5])
    steps = solve_periodic_contact(surf, loads, film_modulus_mpa=2739.0, film_poisson=0.33,
                                   film_thickness_mm=0.09, hardness_mpa=hardness)
    closure = bearing_area_closure_mm(surf, loads, hardness)
    for load, step, c in zip(loads, steps, closure):
        assert step.contact_fraction == pytest.approx(load / hardness, rel=0.05)
        assert step.closure_mm == pytest.approx(c, rel=0.05)


def test_elastic_contact_fraction_against_persson():
    """Elastic, light load: A/A0 = kappa p / (E* h'). Persson's theory gives kappa =
    sqrt(8/pi) = 1.6; published boundary-element and molecular-dynamics values lie at
    1.6-2.5 (Hyun et al. 2004, Phys. Rev. E 70:026117; Yastrebov et al. 2015, Tribol.
    Lett. 56:171), above the theory, which neglects the spots' interaction."""
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=256, size_um=200.0, rolloff_wavelength_um=50.0)
    e, nu = 2739.0, 0.33
    e_star = e / (1 - nu ** 2)
    load = 0.02 * e_star * surf.rms_slope
    step = solve_periodic_contact(surf, [load], film_modulus_mpa=e, film_poisson=nu,
                                  film_thickness_mm=1e6, hardness_mpa=math.inf,
                                  steel_modulus_mpa=RIGID)[0]
    persson = persson_contact_fraction(load, e_star, surf.rms_slope)
    kappa = step.contact_fraction / (load / (e_star * surf.rms_slope))
    assert 1.6 <= kappa <= 2.6
    assert 1.0 <= step.contact_fraction / persson <= 1.6


def test_law_is_cached_monotone_and_reports_local_pressures():
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    law = rough_contact_law(surf, 2739.0, 0.33, 0.09)
    assert rough_contact_law(surf, 2739.0, 0.33, 0.09) is law
    assert isinstance(law, TabularLaw)
    assert all(s.converged for s in law.steps)
    p = np.geomspace(0.01, 2 * PET_HARDNESS_MPA, 50)
    c = law.closure_mm(p)
    assert np.all(np.diff(c) >= 0) and law.closure_mm(np.zeros(1))[0] == 0.0
    # a few um of closure: the order of the RMS height (1.9 um) to its peak height
    assert 1e-3 * surf.rms_um < law.closure_mm(np.array([50.0]))[0] < 1e-3 * 6 * surf.rms_um
    # local pressures: at the activation pressure of HS part of the area is above it,
    # part below; above the hardness-capped range nearly all of it
    frac = law.fraction_above(50.0, np.array([10.0, 50.0, 400.0]))
    assert 0.0 < frac[0] < frac[1] < 1.0 and frac[2] > 0.95
    # the real contact fraction carries at most H: A/A0 >= p/H
    for s in law.steps:
        assert s.contact_fraction >= s.nominal_pressure_mpa / PET_HARDNESS_MPA - 1e-9


def test_law_sent_to_a_worker_reads_the_same_pressures():
    import pickle

    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    law = rough_contact_law(surf, 2739.0, 0.33, 0.09)
    sent = pickle.dumps(law, protocol=pickle.HIGHEST_PROTOCOL)
    maps = sum(s.pressure_mpa.nbytes for s in law.steps)
    assert len(sent) < 1.5 * maps  # without the sorted float64 copies (twice the float32 maps)
    back = pickle.loads(sent)
    p = np.geomspace(0.01, 2 * PET_HARDNESS_MPA, 40)
    for level in (5.0, 50.0, 150.0):
        np.testing.assert_array_equal(back.fraction_above(level, p), law.fraction_above(level, p))
    np.testing.assert_array_equal(back.closure_mm(p), law.closure_mm(p))


@pytest.mark.parametrize("hardness", [40.0, 300.0, math.inf])
def test_projection_onto_the_capped_pressures_of_a_given_mean(hardness):
    """The projected-gradient step's projection against a second method: the shift mu from scipy's brentq on
    mean(clip(x - mu, 0, H)) = mean_p, from a cold start and from a poor warm start alike."""
    from scipy.optimize import brentq

    from filmcal.contact.roughness import _project

    rng = np.random.default_rng(5)
    for trial in range(6):
        x = rng.standard_normal((64, 64)) * rng.uniform(1.0, 200.0) + rng.uniform(-100.0, 100.0)
        mean_p = rng.uniform(0.05, 0.9) * (hardness if math.isfinite(hardness) else 50.0)
        mu_ref = brentq(lambda mu: np.clip(x - mu, 0.0, hardness).mean() - mean_p,
                        x.min() - (hardness if math.isfinite(hardness) else mean_p) - 1.0, x.max() + 1.0,
                        xtol=1e-14, rtol=1e-15)
        reference = np.clip(x - mu_ref, 0.0, hardness)
        for start in (None, mu_ref + rng.normal(0.0, 30.0)):
            p, mu = _project(x, mean_p, hardness, start)
            assert mu == pytest.approx(mu_ref, rel=1e-10, abs=1e-9)
            assert p.mean() == pytest.approx(mean_p, rel=1e-11)
            np.testing.assert_allclose(p, reference, rtol=0.0, atol=1e-9 * max(1.0, mean_p))
    # a mean so small that the bracket's width stops the iteration: the pressures still belong to the shift
    x = rng.standard_normal((64, 64)) * 50.0
    p, mu = _project(x, 1e-12, hardness)
    np.testing.assert_array_equal(p, np.clip(x - mu, 0.0, hardness))
    assert p.mean() == pytest.approx(1e-12, rel=1e-3)


def test_expected_stain_keeps_each_keys_means_apart(tmp_path):
    """The law keeps its step means under the caller's key: a second function under its own key reads its own
    values, and the kept means give what a fresh computation gives."""
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    law = rough_contact_law(surf, 2739.0, 0.33, 0.09)
    p = np.linspace(0.0, 1.5 * law.saturation_pressure_mpa, 37)
    calls = []

    def soft(q):
        calls.append(np.size(q))
        return 1.0 - np.exp(-np.asarray(q) / 30.0)

    hard = lambda q: (np.asarray(q) > 120.0).astype(float)  # noqa: E731
    fresh_soft, fresh_hard = law.expected_stain(soft, p), law.expected_stain(hard, p)
    assert not np.allclose(fresh_soft, fresh_hard)
    for _ in range(2):
        np.testing.assert_array_equal(law.expected_stain(soft, p, key="soft"), fresh_soft)
        np.testing.assert_array_equal(law.expected_stain(hard, p, key="hard"), fresh_hard)
    # kept: a repeated call under its key evaluates no step's local pressures again (only the part above the top)
    calls.clear()
    law.expected_stain(soft, p, key="soft")
    assert max(calls, default=0) < law.steps[0].pressure_mpa.size
    # not sent along: a law read back (from a worker's pickle or its file) computes its means afresh
    import pickle

    from filmcal.contact.rough_law_file import load_rough_law, save_rough_law

    assert pickle.loads(pickle.dumps(law))._stain_means == {}
    assert load_rough_law(save_rough_law(law, tmp_path / "law.npz"))._stain_means == {}
    # above the last step: the mean over every local pressure of that step, shifted by the extra pressure
    extra = np.array([0.5, 20.0, 150.0])
    last = law.steps[-1].pressure_mpa.astype(float).ravel()
    direct = [soft(last + e).mean() for e in extra]
    assert law.expected_stain(soft, law.saturation_pressure_mpa + extra, key="soft") == pytest.approx(direct,
                                                                                                      abs=1e-4)
    # the step function's mean at a solved step is the fraction above its level
    step = law.steps[len(law.steps) // 2].nominal_pressure_mpa
    assert law.expected_stain(hard, np.array([step]), key="hard")[0] == pytest.approx(
        law.fraction_above(120.0, np.array([step]))[0], abs=1e-12)


def test_rough_flat_enlarges_a_sphere_contact():
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    law = rough_contact_law(surf, 2739.0, 0.33, 0.09)
    film = FilmLayer(2739.0, 0.33, 0.09)
    smooth = sphere_on_flat_contact(450.0, 50e3, film=film, spacing_mm=0.2)
    rough = sphere_on_flat_contact(450.0, 50e3, film=film, law=law, spacing_mm=0.2)
    assert rough.converged
    assert rough.area_mm2 > 1.02 * smooth.area_mm2
    assert rough.max_pressure_mpa < smooth.max_pressure_mpa


def test_measured_maps_from_csv_and_image(tmp_path):
    from PIL import Image

    rng = np.random.default_rng(0)
    heights = rng.normal(size=(32, 40))
    path = tmp_path / "map.csv"
    np.savetxt(path, heights, delimiter=",", header="heights in um", comments="")
    surf = RoughSurface.from_csv(path, pixel_um=0.5)
    assert surf.heights_um == pytest.approx(heights - heights.mean())
    assert surf.size_um == (16.0, 20.0)
    grey = (np.linspace(0, 65535, 32 * 32).reshape(32, 32)).astype(np.uint16)
    img = tmp_path / "map.png"
    Image.fromarray(grey).save(img)
    surf = RoughSurface.from_image(img, pixel_um=1.0, height_range_um=4.0)
    assert np.ptp(surf.heights_um) == pytest.approx(4.0, rel=1e-3)


@pytest.mark.parametrize("kwargs, match", [
    ({"ra_um": -1.0}, "ra_um"),
    ({"ra_um": 1.0, "rms_um": 1.0}, "exactly one"),
    ({"ra_um": 1.0, "hurst": 1.5}, "hurst"),
    ({"ra_um": 1.0, "n": 15}, "n must"),
    ({"ra_um": 1.0, "rolloff_wavelength_um": 500.0}, "rolloff_wavelength_um"),
    ({"ra_um": 1.0, "rms_slope": 0.2, "cutoff_wavelength_um": 5.0}, "not both"),
])
def test_bad_surface_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RoughSurface.synthetic(**kwargs)


def test_bad_law_parameters(tmp_path):
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=32, size_um=50.0, rolloff_wavelength_um=25.0)
    with pytest.raises(ValueError, match="film_modulus_mpa"):
        rough_contact_law(surf, 0.0, 0.33, 0.09)
    with pytest.raises(ValueError, match="hardness_mpa"):
        rough_contact_law(surf, 2739.0, 0.33, 0.09, hardness_mpa=-3.0)
    with pytest.raises(ValueError, match="not found"):
        RoughSurface.from_csv(tmp_path / "missing.csv", pixel_um=1.0)
    with pytest.raises(ValueError, match="flat"):
        RoughSurface(np.ones((16, 16)), 1.0)


def test_law_lies_above_the_rigid_plastic_bearing_curve_and_tends_to_it():
    """Elastic deformation only adds closure to the rigid-plastic (Abbott-Firestone) limit;
    the stiffer the film, the closer the law comes to it (HHS within 10 % at 10-130 MPa)."""
    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    p = np.array([10.0, 50.0, 130.0])
    bearing = bearing_area_closure_mm(surf, p, PET_HARDNESS_MPA)
    closures = [rough_contact_law(surf, e, 0.33, 0.09).closure_mm(p) for e in (768.0, 2739.0, 6291.0)]
    for c in closures:
        assert np.all(c >= 0.99 * bearing)
    assert np.all(closures[0] > closures[1]) and np.all(closures[1] > closures[2])
    assert closures[2] == pytest.approx(bearing, rel=0.10)


def test_mostly_plastic_steps_meet_the_contact_conditions_whatever_the_path(monkeypatch):
    """A stiff film under a soft cap: the CG fails at the first load and the later loads go straight to the
    projected gradient. Every step still meets the contact conditions, and its closure is the one of that load
    solved alone from a cold start (the problem is strictly convex: one solution)."""
    from filmcal.contact import roughness

    surf = RoughSurface.synthetic(ra_um=1.5, seed=0, n=128, size_um=100.0, rolloff_wavelength_um=25.0)
    hardness = 50.0
    loads = np.geomspace(0.5, 45.0, 6)
    film = dict(film_modulus_mpa=2800.0, film_poisson=0.33, film_thickness_mm=0.09, hardness_mpa=hardness)
    cg = []
    real = roughness._pk_step

    def counted(*args, **kwargs):
        out = real(*args, **kwargs)
        cg.append(out[3])
        return out

    monkeypatch.setattr(roughness, "_pk_step", counted)
    steps = solve_periodic_contact(surf, loads, **film)
    assert cg == [False]  # the CG ran once, failed, and was not tried again
    kernel = roughness._PeriodicKernel(surf.heights_um.shape, surf.pixel_um, 2800.0, 0.33, 90.0,
                                       roughness.STEEL_MODULUS_MPA, roughness.STEEL_POISSON)
    for load, step in zip(loads, steps):
        p = step.pressure_mpa.astype(float)
        assert p.mean() == pytest.approx(load, rel=1e-5)
        assert roughness._kkt_violation(kernel, surf.heights_um, p, hardness) < 1e-3
        alone = solve_periodic_contact(surf, [load], **film)[0]
        assert step.closure_mm == pytest.approx(alone.closure_mm, rel=1e-5)
    assert steps[-1].plastic_fraction > 0.5
