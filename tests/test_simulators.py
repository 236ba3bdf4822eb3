"""A lab's own simulator in the calibration: a Python function or an external command in place of the FE."""
from __future__ import annotations

import csv
import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
import pytest

from filmcal._errors import InputError
from filmcal.campaign.command import ModelFailure
from filmcal.campaign.simulator import Simulator
from filmcal.films import get_film

TESTS = Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))
from toymodels import ToyRadiusModel, toy_simulator  # noqa: E402


def test_a_python_simulator_is_read_by_every_imprint_model_from_its_profile():
    """Hertz-shaped profile p0 sqrt(1 - r^2/a^2): where p = p_act the radius is a sqrt(1 - (p_act / p0)^2)."""
    hs = get_film("HS")
    model = Simulator(python="toymodels:toy_simulator").model([("activation", hs)], ".")
    point = {"modulus_mpa": 2000.0, "poisson": 0.33, "sphere_radius_mm": 450.0, "force_kn": 50.0,
             "film_thickness_mm": 0.09, "kinematics": "small"}  # columns a run does not take are left out
    out = model(point)
    a = float(ToyRadiusModel().predict(2000.0, 0.33, 450.0, 50e3)[0])
    p0 = 3 * 50e3 / (2 * math.pi * a**2)
    assert out["contact_radius_mm"] == a
    # read from the sampled profile (1501 points over 1.5 a): to within one sample spacing of the closed form
    assert out["radius_activation_HS_mm"] == pytest.approx(a * math.sqrt(1 - (50.0 / p0) ** 2), abs=1.5 * a / 1500)


def test_a_simulator_is_checked_before_any_run_and_its_failures_have_reasons(tmp_path):
    with pytest.raises(InputError, match="one of a Python function, a command or a UM-Bridge model"):
        Simulator()
    with pytest.raises(InputError, match="MODULE:FUNCTION"):
        Simulator(python="not a spec")
    with pytest.raises(InputError, match="cannot import"):
        Simulator(python="no_such_module_here:f")
    with pytest.raises(InputError, match=r"\{radius\}.*are not inputs of a run"):
        Simulator(command="sim --r {radius}")
    script = tmp_path / "sim.py"
    script.write_text("import json, sys\nprint(json.dumps({'contact_radius_mm': float(sys.argv[1]) - 100}))\n")
    model = Simulator(command=f"{sys.executable} {script} {{force_kn}}").model([], tmp_path / "work")
    point = {"modulus_mpa": 2000.0, "poisson": 0.33, "sphere_radius_mm": 450.0, "film_thickness_mm": 0.09}
    assert model({**point, "force_kn": 107.5}, point_id="p1")["contact_radius_mm"] == 7.5
    with pytest.raises(ModelFailure, match="no finite contact_radius_mm > 0"):
        model({**point, "force_kn": 50.0}, point_id="p2")


class _ToyUMBridge(BaseHTTPRequestHandler):
    """A UM-Bridge model of the toy law (protocol 1.0, as any language's server would answer)."""

    def log_message(self, *args):
        pass

    def do_POST(self):  # noqa: N802
        request = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        if request.get("name") != "toy":
            status, body = 400, {"error": {"type": "ModelNotFound", "message": f"no model {request.get('name')}"}}
        else:
            e, nu, r, f, t = request["input"][0]
            out = toy_simulator(dict(modulus_mpa=e, poisson=nu, sphere_radius_mm=r, force_kn=f, film_thickness_mm=t))
            status, body = 200, {"output": [[out["contact_radius_mm"]], out["radius_mm"], out["pressure_mpa"]]}
        data = json.dumps(body).encode()
        self.send_response(status)
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)


def test_a_umbridge_model_runs_the_points_and_its_profile_is_read():
    server = ThreadingHTTPServer(("127.0.0.1", 0), _ToyUMBridge)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}"
        hs = get_film("HS")
        point = {"modulus_mpa": 2000.0, "poisson": 0.33, "sphere_radius_mm": 450.0, "force_kn": 50.0,
                 "film_thickness_mm": 0.09}
        served = Simulator(umbridge=url, umbridge_model="toy").model([("activation", hs)], ".")(point)
        local = Simulator(python="toymodels:toy_simulator").model([("activation", hs)], ".")(point)
        assert served == local
        assert Simulator(umbridge=url, umbridge_model="toy").spec() == {"umbridge": url, "model": "toy"}
        with pytest.raises(ModelFailure, match="ModelNotFound: no model other"):
            Simulator(umbridge=url, umbridge_model="other").model([], ".")(point)
    finally:
        server.shutdown()
    with pytest.raises(InputError, match="needs --umbridge-model"):
        Simulator(umbridge="http://127.0.0.1:1")
    with pytest.raises(ModelFailure, match="cannot be reached"):
        Simulator(umbridge="http://127.0.0.1:1", umbridge_model="toy", timeout_s=5).model([], ".")(point)


DATASET_CASES = [(300, 25), (300, 50), (450, 25), (450, 50), (450, 75), (450, 100), (600, 50), (600, 100)]


def _dataset(path: Path, modulus_mpa: float, seed: int = 0) -> None:
    """Two repeats per case at a known E of the toy law, with 0.01 mm Gaussian scatter."""
    rng = np.random.default_rng(seed)
    rows = ["film,sphere_radius_mm,force_kn,measured_radius_mm,repeat"]
    for radius, force in DATASET_CASES:
        a = float(ToyRadiusModel().predict(modulus_mpa, 0.33, radius, 1e3 * force)[0])
        rows += [f"HS,{radius},{force},{a + 0.01 * rng.standard_normal():.4f},{k}" for k in (1, 2)]
    path.write_text("\n".join(rows) + "\n")


def _calibrate(tmp_path: Path, *simulator: str, study: str = "st", env: dict | None = None, **kw):
    cmd = [sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "lot.csv"), "--film", "HS",
           "--imprint-model", "activation", "--kinematics", "small", "--study-dir", str(tmp_path / study),
           "--train-runs", "30", "--test-runs", "10", "--max-steps", "3000", "--workers", "2", "--json", *simulator]
    env = {**os.environ, "PYTHONPATH": str(TESTS), **(env or {})}
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env, **kw)


def test_a_python_simulator_of_another_law_recovers_its_own_modulus(tmp_path):
    """The toy law's own E = 2000 MPa, read through the activation model from its profiles."""
    _dataset(tmp_path / "lot.csv", 2000.0)
    # the measured radii are the toy law's edge; calibrating the edge reading recovers E
    p = _calibrate(tmp_path, "--simulator-python", "toymodels:toy_simulator")
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    assert out["fe_options"]["simulator"] == {"python": "toymodels:toy_simulator"}
    edge = subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "lot.csv"),
                           "--film", "HS", "--imprint-model", "edge", "--kinematics", "small", "--study-dir",
                           str(tmp_path / "st"), "--train-runs", "30", "--test-runs", "10", "--max-steps", "3000",
                           "--workers", "2", "--json", "--simulator-python", "toymodels:toy_simulator"],
                          capture_output=True, text=True, timeout=900, env={**os.environ, "PYTHONPATH": str(TESTS)})
    assert edge.returncode == 0, edge.stderr[-2000:]
    e = json.loads(edge.stdout)["modulus_mpa"]
    assert e["ci90"][0] < 2000.0 < e["ci90"][1]
    assert abs(e["median"] / 2000.0 - 1) < 0.03
    # the activation reading lies inside the edge: the same radii need a softer film
    assert out["modulus_mpa"]["median"] < e["median"]


def test_the_half_space_film_model_as_a_python_simulator_recovers_its_own_modulus(tmp_path):
    """Another law than the calibrated FE, with physics: filmcal's half-space film model (film springs
    between two half-spaces, its edge reading) makes a lot at E = 1500 MPa, nu 0.33, 0.09 mm (two repeats,
    0.01 mm scatter); calibrated through --simulator-python on that model, its own E comes back."""
    sys.path.insert(0, str(TESTS))
    from toymodels import halfspace_simulator

    rng = np.random.default_rng(5)
    rows = ["film,sphere_radius_mm,force_kn,measured_radius_mm,repeat"]
    for radius, force in DATASET_CASES:
        a = halfspace_simulator(dict(modulus_mpa=1500.0, poisson=0.33, sphere_radius_mm=radius, force_kn=force,
                                     film_thickness_mm=0.09))["contact_radius_mm"]
        rows += [f"HS,{radius},{force},{a + 0.01 * rng.standard_normal():.4f},{k}" for k in (1, 2)]
    (tmp_path / "lot.csv").write_text("\n".join(rows) + "\n")
    cmd = [sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "lot.csv"), "--film", "HS",
           "--imprint-model", "edge", "--kinematics", "small", "--study-dir", str(tmp_path / "st"),
           "--train-runs", "30", "--test-runs", "10", "--max-steps", "3000", "--workers", "2", "--json",
           "--simulator-python", "toymodels:halfspace_simulator"]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900,
                       env={**os.environ, "PYTHONPATH": str(TESTS), "OMP_NUM_THREADS": "1"})
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    assert out["fe_options"]["simulator"] == {"python": "toymodels:halfspace_simulator"}
    e = out["modulus_mpa"]
    assert e["ci90"][0] < 1500.0 < e["ci90"][1], e
    assert abs(e["median"] / 1500.0 - 1) < 0.03, e


SCRIPT = textwrap.dedent("""\
    import json, os, sys, time
    sys.path.insert(0, {tests!r})
    from toymodels import toy_simulator
    e, nu, r, f, t = (float(v) for v in sys.argv[1:6])
    with open({log!r}, "a") as fh:
        fh.write(os.environ["FILMCAL_POINT_ID"] + "\\n")
    time.sleep({sleep})
    if f > 95.0:
        print("solver diverged at high load", file=sys.stderr)
        sys.exit(3)
    out = toy_simulator(dict(modulus_mpa=e, poisson=nu, sphere_radius_mm=r, force_kn=f, film_thickness_mm=t))
    print(json.dumps({{"contact_radius_mm": out["contact_radius_mm"]}}))
""")


def test_a_command_simulator_fails_on_some_points_and_resumes_without_running_any_twice(tmp_path):
    import time

    _dataset(tmp_path / "lot.csv", 2000.0)
    log = tmp_path / "runs.log"
    script = tmp_path / "sim.py"
    script.write_text(SCRIPT.format(tests=str(TESTS), log=str(log), sleep=0.2))
    template = f"{sys.executable} {script} {{modulus_mpa}} {{poisson}} {{sphere_radius_mm}} {{force_kn}} " \
               "{film_thickness_mm}"
    args = ["--simulator-command", template, "--imprint-model", "edge"]
    first = subprocess.Popen([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "lot.csv"),
                              "--film", "HS", "--kinematics", "small", "--study-dir", str(tmp_path / "st"),
                              "--train-runs", "30", "--test-runs", "10", "--max-steps", "3000", "--workers", "2",
                              "--json", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             env={**os.environ, "PYTHONPATH": str(TESTS)}, start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and (not log.exists() or len(log.read_text().split()) < 12):
        time.sleep(0.1)
    os.killpg(first.pid, signal.SIGKILL)  # the command, its workers and their runs, mid-campaign: a power cut
    first.wait(timeout=30)
    done_before = len(log.read_text().split())
    assert 12 <= done_before < 40
    p = _calibrate(tmp_path, *args)
    assert p.returncode == 0, p.stderr[-2000:]
    ids = log.read_text().split()
    # every point ran once, but the one or two the kill cut short (they never answered, so they ran again)
    # 30 + 10 design runs and 3 moduli at each of the 8 cases (at most --train-runs in all)
    assert len(ids) - len(set(ids)) <= 2 and len(set(ids)) == 40 + 3 * len(DATASET_CASES)
    out = json.loads(p.stdout)
    assert out["modulus_mpa"]["ci90"][0] < 2000.0 < out["modulus_mpa"]["ci90"][1]
    stores = list((tmp_path / "st").rglob("*.sqlite"))
    assert len(stores) == 1
    with sqlite3.connect(stores[0]) as db:
        failed = db.execute("SELECT reason FROM runs WHERE status = 'failed'").fetchall()
    assert failed and all("exit status 3" in r and "solver diverged at high load" in r for (r,) in failed)


def test_the_lab_example_runs_end_to_end(tmp_path):
    """examples/lab at its fast size: the lab's own solver behind a deck and a results file, calibrated, and its
    imprints corrected; the data were made at E = 2200 MPa."""
    p = subprocess.run([sys.executable, str(TESTS.parent / "examples" / "lab" / "workflow.py"), "--fast", "--out-dir",
                        str(tmp_path / "lab")], capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    lo, hi = (float(v) for v in p.stdout.split("90 % [")[1].split("]")[0].split(", "))
    assert lo < 2200.0 < hi
    with open(tmp_path / "lab" / "corrected.csv", newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    assert len(rows) == 4 and all(r["status"].startswith("ok") for r in rows)
    assert all(float(r["area_mm2"]) < float(r["measured_area_mm2"]) for r in rows)  # the film enlarges
    assert len(list((tmp_path / "lab" / "runs").glob("runs-*.sqlite"))) == 1  # its --run-store: all in its folder


def test_the_in_house_fe_as_an_external_command_gives_the_in_house_posterior(tmp_path):
    """`filmcal fem --json` wrapped as `--simulator-command`: its runs are the in-house FE's (the JSON keeps every
    digit), so the calibration's posterior is the in-house one to the last digit."""
    import json
    import shlex
    import subprocess
    import sys

    (tmp_path / "lab.csv").write_text("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,75,1.2\n"
                                      "HS,300,50,1.1\nHS,600,100,1.3\nHS,375,25,0.9\n")
    fem = " ".join(map(shlex.quote, [sys.executable, "-m", "filmcal.cli", "fem"]))
    template = (f"{fem} --sphere-radius-mm {{sphere_radius_mm}} --force-kn {{force_kn}} --film-modulus-mpa "
                "{modulus_mpa} --film-poisson {poisson} --film-thickness-mm {film_thickness_mm} --json")

    def calibrate(study: str, *simulator: str) -> dict:
        p = subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "lab.csv"),
                            "--film", "HS", "--imprint-model", "edge", "--study-dir", str(tmp_path / study),
                            "--train-runs", "24", "--test-runs", "8", "--max-steps", "2000", "--json", *simulator],
                           capture_output=True, text=True, timeout=900)
        assert p.returncode == 0, p.stderr[-2000:]
        return json.loads(p.stdout)

    in_house = calibrate("in-house")
    wrapped = calibrate("wrapped", "--simulator-command", template)
    assert wrapped["modulus_mpa"] == in_house["modulus_mpa"]
    assert wrapped["sigma_mm"] == in_house["sigma_mm"]
    assert "simulator" in wrapped["fe_options"] and "simulator" not in in_house["fe_options"]


def test_the_design_runs_the_data_cases_so_the_surrogate_is_exact_where_the_calibration_asks(tmp_path):
    """The toy law is analytic: at the dataset's cases the surrogate's mean is checked against it. With runs
    along ln E at each case (`moduli_per_case`), those runs are in the surrogate's training set: at a case and
    one of their moduli its latent std is at most the noise's (a GP conditioned on a noisy observation at a
    point, Rasmussen & Williams eq. 2.24); the hypercube's runs are reused, not run twice."""
    from filmcal.study import CalibrationSpec, FESettings, Study

    _dataset(tmp_path / "lot.csv", 2000.0)
    study = Study(tmp_path / "st", create=True, run_store=tmp_path / "store")
    sim = Simulator(python="toymodels:toy_simulator")
    R = np.array([r for r, _ in DATASET_CASES], float)
    F = np.array([1e3 * f for _, f in DATASET_CASES], float)
    e_case = float(np.geomspace(400.0, 20000.0, 4)[1])  # one of the cases' moduli
    with study.writing("test"):
        for k in (0, 4):
            spec = CalibrationSpec("HS", imprint="edge", fe=FESettings(n_train=40, n_test=5, moduli_per_case=k,
                                                                        simulator=sim))
            fe = study.as_calibrated(spec, dataset=tmp_path / "lot.csv").fe
            assert fe.case_runs == len(DATASET_CASES) * k
            assert sorted(fe.case_points) == (sorted((float(r), float(f), 0.33) for r, f in DATASET_CASES) if k else [])
            model, _, _ = study.radius_model(fe, "contact_radius_mm", workers=1)
            for e in (2000.0, e_case):
                mean, std = model.predict(e, 0.33, R, F)
                assert np.all(np.abs(mean - ToyRadiusModel().predict(e, 0.33, R, F)[0]) <= 3 * std + 1e-4)
            gp = model.surrogate
            _, T = gp._gp_inputs({"modulus_mpa": np.full(R.shape, e_case), "poisson": np.full(R.shape, 0.33),
                                  "sphere_radius_mm": R, "force_kn": F / 1e3})
            latent = gp.predict_gp(T)[1] / np.sqrt(gp.noise_variance_)  # in the GP's own coordinates
            if k:  # without the cases' runs the corner case (300 mm, 25 kN) lies above it (1.07 when written)
                assert np.all(latent <= 1.0)
        runs = study.fe_runs(fe, workers=1)
    assert len(runs["X_train"]["modulus_mpa"]) == 40 + 4 * len(DATASET_CASES)
    with sqlite3.connect(runs["store"]) as db:  # the hypercube's 45 runs once, the cases' 32 beside them
        assert db.execute("select count(*) from runs").fetchone()[0] == 45 + 4 * len(DATASET_CASES)


def test_a_posterior_on_the_design_alone_is_superseded_by_one_with_the_cases_runs(tmp_path):
    """A folder calibrated before the cases' runs existed and again after keeps both posteriors; a reader
    takes the one whose surrogate has the cases' runs, and names no option it could not give."""
    from filmcal.study import CalibrationSpec, FESettings, Study

    _dataset(tmp_path / "lot.csv", 2000.0)
    study = Study(tmp_path / "st", create=True, run_store=tmp_path / "store")
    sim = Simulator(python="toymodels:toy_simulator")
    with study.writing("test"):
        made = [study.calibrate(CalibrationSpec("HS", imprint="edge", max_steps=1500,
                                                fe=FESettings(n_train=40, n_test=5, moduli_per_case=k, simulator=sim)),
                                dataset=tmp_path / "lot.csv", workers=1)[1] for k in (0, 4)]
    assert made[0] != made[1] and len(study.manifest.artefacts("posterior")) == 2
    (path, spec), = study.posteriors("HS")
    assert path == made[1] and spec["fe"]["moduli_per_case"] == 4
    assert study.posterior("HS")[1] == made[1]
