"""`filmcal correct` starts fast: a saved surrogate predicted with numpy alone, wheel-rail solves shared by
the models of one film kinematics and kept in the study, and only what the form needs imported."""
from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import qmc

from filmcal.contact.film import FilmModel
from filmcal.correction.wheelrail import SupportAreas, WheelRailCorrector, support_moduli
from filmcal.films import get_film
from filmcal.surrogate import GPSurrogate, save_surrogate
from filmcal.surrogate.io import load_surrogate
from filmcal.surrogate.radius import load_for_prediction
from filmcal.surrogate.saved import SETTINGS, load_saved_surrogate

NAMES = ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn")
HEAVY = ("sklearn", "scipy.stats", "emcee", "pandas", "arviz", "h5py")


def heavy(modules) -> set[str]:
    """The modules of `modules` that belong to a heavy package (`HEAVY`)."""
    return {m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY)}


def _excess(X: np.ndarray) -> np.ndarray:
    """A smooth positive stand-in for the radius excess over Hertz (a test function, not physics)."""
    e, nu, r, f = X.T
    return 0.2 * (2800.0 / e) ** 0.6 * (r / 450.0) ** 0.3 * (f / 75.0) ** 0.2 * (1.0 + nu)


def _fit(scatter: float) -> GPSurrogate:
    u = qmc.LatinHypercube(4, rng=3).random(40)
    lo, hi = np.array([np.log(400.0), 0.29, 300.0, 20.0]), np.array([np.log(2e4), 0.37, 600.0, 110.0])
    X = lo + u * (hi - lo)
    X[:, 0] = np.exp(X[:, 0])
    y = _excess(X) * (1.0 + scatter * np.random.default_rng(5).standard_normal(len(X)))
    return GPSurrogate(NAMES, "radius_excess_mm", log_inputs=("modulus_mpa", "sphere_radius_mm", "force_kn"),
                       output_transform="log", n_restarts=1, random_state=0).fit(X, y)


@pytest.fixture(scope="module")
def fitted() -> GPSurrogate:
    """A surrogate of data with 1 % scatter (like FE jitter): kernel matrix condition ~1e8, as the study's."""
    return _fit(0.01)


@pytest.fixture()
def saved(fitted, tmp_path):
    save_surrogate(fitted, tmp_path / "s")
    return tmp_path / "s"


def _queries(n=500):
    rng = np.random.default_rng(1)
    return {"modulus_mpa": np.exp(rng.uniform(np.log(500.0), np.log(1.5e4), n)), "poisson": rng.uniform(0.3, 0.36, n),
            "sphere_radius_mm": rng.uniform(300.0, 600.0, n), "force_kn": rng.uniform(25.0, 100.0, n)}


def test_numpy_prediction_equals_the_fitted_surrogate(fitted, saved):
    """The mean to 1e-10; the std to 1e-7 (both codes round c - |L^-1 k|^2, which cancels where the std is small)."""
    fast = load_saved_surrogate(saved)
    X = _queries()
    for noise in (False, True):
        mean_a, std_a = fitted.predict(X, return_std=True, noise=noise)
        mean_b, std_b = fast.predict(X, return_std=True, noise=noise)
        np.testing.assert_allclose(mean_b, mean_a, rtol=1e-10, atol=0)
        np.testing.assert_allclose(std_b, std_a, rtol=1e-7, atol=0)
    np.testing.assert_allclose(fast.predict(X), fitted.predict(X), rtol=1e-10)
    train = dict(zip(NAMES, fitted.X_train_.T))
    np.testing.assert_allclose(fast.predict(train), fitted.predict(train), rtol=1e-10)
    # the log marginal likelihood is recomputed from a kernel matrix of condition ~1e8: two BLAS builds agree to
    # about cond * eps = 1e-8 (numpy 2.4 on Python 3.13 differed from scikit-learn's value by 3e-10)
    assert fast.log_marginal_likelihood_value_ == pytest.approx(fitted.log_marginal_likelihood_value_, rel=1e-8)
    assert fast.input_names_ == fitted.input_names_


def test_a_nearly_singular_surrogate_is_read_as_the_fit_computed_it(tmp_path):
    """Noise-free smooth data: condition ~1e13, where numpy's and scipy's Cholesky factors part in the 8th
    digit; `load_for_prediction` then reads the files with scipy, as the fit did, or (where the two LAPACK
    builds agree on the log marginal likelihood) with numpy. Two correct factorisations of a matrix of
    condition 1e13 may part by up to cond * eps ~ 1e-3 in a prediction; seen: 1e-9..1.3e-8 (numpy 2.4/2.5,
    scipy 1.17/1.18). 1e-6 leaves that margin, while a reader that mishandles the noise variance or a
    transform is off by 1e-3 or more."""
    exact = _fit(0.0)
    save_surrogate(exact, tmp_path / "e")
    loaded = load_for_prediction(tmp_path / "e")
    X = _queries(50)
    np.testing.assert_allclose(loaded.predict(X), exact.predict(X), rtol=1e-6)


def test_the_saved_settings_are_the_estimators():
    assert sorted(SETTINGS) == sorted(GPSurrogate().get_params())


@pytest.mark.parametrize("edit, message", [
    (lambda m: m["kernel"]["k1"].update(type="DotProduct"), "unknown kernel type"),
    (lambda m: m["kernel"]["k2"].update(evil="x"), "unknown parameter"),
    (lambda m: m["kernel"]["k1"]["k2"].update(nu=1.5), "Matern"),
    (lambda m: m.update(format_version=99), "format version"),
    (lambda m: m["params"].update(extra=1), "unknown setting"),
    (lambda m: m.update(arrays="../elsewhere.npz"), "file name"),
    (lambda m: m["kernel"]["k1"]["k2"].update(length_scale=[1.0, 2.0, 3.0, 4.0]), "log marginal likelihood"),
    (lambda m: m.pop("kernel"), "kernel"),
])
def test_the_numpy_reader_refuses_what_load_surrogate_refuses(saved, edit, message):
    path = saved.with_name("s.json")
    meta = json.loads(path.read_text())
    edit(meta)
    path.write_text(json.dumps(meta))
    for load in (load_saved_surrogate, load_surrogate):
        with pytest.raises(ValueError, match=message):
            load(saved)


@pytest.mark.parametrize("index", [0, 17])
def test_the_numpy_reader_refuses_a_training_value_changed_by_a_thousandth(saved, index):
    """One stored radius changed by 0.1 % is refused: by the training data's SHA-256 recorded with them, and in a
    file written before that digest by the log marginal likelihood (its tolerance, 1e-4 relative for the rounding
    of nearly singular kernels, still sees the likelihood move by 5e-4..2e-3)."""
    arrays = dict(np.load(saved.with_name("s.npz")))
    arrays["y_train"][index] *= 1.001
    np.savez(saved.with_name("s.npz"), **arrays)
    with pytest.raises(ValueError, match="not those the surrogate was saved with"):
        load_saved_surrogate(saved)
    meta = json.loads(saved.with_name("s.json").read_text())
    del meta["arrays_sha256"]
    saved.with_name("s.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="log marginal likelihood"):
        load_saved_surrogate(saved)


def test_prediction_and_the_correct_command_import_no_heavy_stage(saved):
    code = ("import sys, numpy as np\n"
            "import filmcal.cli as cli; cli.build_parser()\n"
            "import filmcal.study, filmcal.commands.correct, filmcal.correction.sphere, filmcal.correction.wheelrail\n"
            "from filmcal.surrogate.saved import load_saved_surrogate\n"
            "from filmcal.surrogate.radius import SurrogateRadiusModel\n"
            f"m = SurrogateRadiusModel(load_saved_surrogate({str(saved)!r}))\n"
            "m.predict(np.full(10, 2800.0), 0.33, 450.0, 75e3)\n"
            "print(sorted(sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    modules = set(eval(out.stdout))  # noqa: S307 - our own subprocess's list of names
    assert not heavy(modules)
    assert not {m for m in modules if m.startswith(("scipy", "filmcal.wheelrail.halfspace", "filmcal.calibration"))}


def test_the_capsule_reading_of_a_correction_imports_no_statistics_package():
    """A study's capsule model is built on every correction: its log-normal strengths come from scipy.special."""
    code = ("import sys, numpy as np\n"
            "from filmcal.contact.film import FilmModel\n"
            "from filmcal.contact.imprint import get_imprint_model\n"
            "from filmcal.films import get_film\n"
            "FilmModel(get_film('HS'), 'capsule', 'small')\n"
            "p = get_imprint_model('capsule').stain_probability(np.array([0.0, 50.0, 130.0]), get_film('HS'))\n"
            "print(repr(p.tolist()), sorted(sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    probabilities, modules = out.stdout.split("] ", 1)
    assert not heavy(eval(modules))  # noqa: S307 - our own subprocess's list of names
    # HS spans 50-130 MPa: 2 % of the capsules are weaker than 50 MPa, 2 % stronger than 130 MPa
    assert eval(probabilities + "]") == pytest.approx([0.0, 0.02, 0.98], abs=1e-12)  # noqa: S307


def _lognormal(median, n=600, seed=0):
    rng = np.random.default_rng(seed)
    return {"modulus_mpa": np.exp(rng.normal(np.log(median), 0.08, n)), "sigma_mm": np.full(n, 0.05)}


class DictCache:
    def __init__(self):
        self.areas, self.gets, self.puts = {}, 0, 0

    def get(self, offset_mm, force_n, support):
        self.gets += 1
        return self.areas.get((offset_mm, force_n, tuple(support.moduli_mpa)))

    def put(self, offset_mm, force_n, support, areas):
        self.puts += 1
        self.areas[(offset_mm, force_n, tuple(support.moduli_mpa))] = json.loads(json.dumps(areas))


def test_models_of_one_kinematics_share_their_solves_and_a_cache_replaces_them():
    hs = get_film("HS")
    models = [FilmModel(hs, "edge", "small"), FilmModel(hs, "activation", "small")]

    def build(cache=None):
        cs = [WheelRailCorrector(_lognormal(e, seed=k), m, random_state=k)
              for k, (e, m) in enumerate(zip((2600.0, 3000.0), models))]
        WheelRailCorrector.share_supports(cs, cache=cache)
        return cs

    cache = DictCache()
    shared = build(cache)
    assert shared[0].supports is shared[1].supports
    nodes = support_moduli([c.modulus_mpa_ for c in shared])
    np.testing.assert_array_equal(shared[0].supports.moduli_mpa, nodes)
    first = [c.correct(150.0, -3.0, 100e3) for c in shared]
    assert shared[0].supports.n_solves == 1 + len(nodes)  # one solve without film, one per modulus for both models
    # each model reads its own area of the shared solves: as its own solves at the same moduli
    ratio, _, support = shared[1].area_ratio(-3.0, 100e3)
    own = [shared[1].film_area_mm2(e, -3.0, 100e3) for e in nodes[[0, -1]]]
    np.testing.assert_allclose(support["area_film_mm2"][[0, -1]], own, rtol=1e-12)
    # a second set of correctors reads the cache: no solve, the same answers
    again = build(cache)
    second = [c.correct(150.0, -3.0, 100e3) for c in again]
    assert again[0].supports.n_solves == 0 and cache.puts == 1
    for a, b in zip(first, second):
        np.testing.assert_array_equal(a.samples_mm2, b.samples_mm2)


def test_shared_supports_need_one_film_kinematics():
    hs = get_film("HS")
    with pytest.raises(ValueError, match="kinematics"):
        SupportAreas([FilmModel(hs, "edge", "small"), FilmModel(hs, "edge", "large")],
                     [np.full(5, 2800.0)] * 2, {})


@pytest.mark.slow
def test_correct_of_a_quick_study_keeps_its_solves_and_refuses_a_changed_cache(quick_study, tmp_path):
    """The sphere form imports no heavy stage; the wheel-rail form solves once, the study keeps the solved areas
    (recorded under the manifest's caches, not as an artefact), the next run reads them (no solver imported) with
    the same answer, and a changed cache file is refused."""
    study = tmp_path / "study"
    shutil.copytree(quick_study[0], study)
    wheel = [sys.executable, "-X", "importtime", "-m", "filmcal.cli", "correct", "--film", "HS",
             "--measured-area-mm2", "150", "--offset-mm=-3", "--force-kn", "100", "--study-dir", str(study), "--json"]
    sphere = [*wheel[:6], "--film", "HS", "--sphere-radius-mm", "450", "--force-kn", "75", "--measured-radius-mm",
              "7.12", "--study-dir", str(study), "--json"]

    def run(cmd):
        p = subprocess.run(cmd, capture_output=True, text=True)
        assert p.returncode == 0, p.stderr[-3000:]
        imported = {line.split("|")[-1].strip() for line in p.stderr.splitlines() if line.startswith("import time")}
        return json.loads(p.stdout), imported

    # start without the solved areas that other tests' corrections may have left in the shared quick study
    before = json.loads((study / "study.json").read_text())
    for rel in before.pop("caches", {}):
        (study / rel).unlink(missing_ok=True)
    (study / "study.json").write_text(json.dumps(before))
    artefacts = before["artefacts"]
    out, imported = run(sphere)
    assert not heavy(imported)
    cold, _ = run(wheel)
    manifest = json.loads((study / "study.json").read_text())
    assert manifest["artefacts"] == artefacts  # a correction makes no artefact: the report stays current
    kept = [rel for rel, e in manifest["caches"].items() if e["kind"] == "wheel-rail-supports"]
    assert len(kept) == 1 and (study / kept[0]).exists()
    from filmcal.contact.names import APPLICATION_MODEL_REVISION  # another revision's solves are not read

    assert manifest["caches"][kept[0]]["spec"]["application_model_revision"] == APPLICATION_MODEL_REVISION
    warm, imported = run(wheel)
    assert warm == cold  # read from the study: the same answer
    assert not heavy(imported) and not {m for m in imported if m.startswith(("scipy", "filmcal.wheelrail.halfspace"))}
    areas = json.loads((study / kept[0]).read_text())
    areas["area_no_film_mm2"] *= 1.1
    (study / kept[0]).write_text(json.dumps(areas))
    p = subprocess.run(wheel, capture_output=True, text=True)
    assert p.returncode == 2 and kept[0].split("/")[-1] in p.stderr and "Traceback" not in p.stderr
