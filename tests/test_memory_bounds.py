"""Bounds before work: the memory estimates of the FE mesh, roughness maps and worker processes, and the
commands' refusals when they exceed the memory available now (in-process, `filmcal.cli.main`, with
`filmcal._memory.available_bytes` patched small). No timing assertions: `bench/memory.py` measures."""
from __future__ import annotations

import argparse
import os

import numpy as np
import pytest

from filmcal import _memory, cli
from filmcal._errors import InputError
from filmcal.contact.roughness import rough_law_cost
from filmcal.contact.surface_files import MAX_MAP_PIXELS, PROFILE_ROWS, surface_file_shape
from filmcal.fem import MeshSettings
from filmcal.fem.memory import fe_memory, fe_sizes

GIB = 2**30
FEM = ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--film-modulus-mpa", "2800"]


@pytest.fixture
def small_machine(monkeypatch):
    """The machine has 1 GiB available of 2 GiB."""
    monkeypatch.setattr(_memory, "available_bytes", lambda: 1 * GIB)
    monkeypatch.setattr(_memory, "total_bytes", lambda: 2 * GIB)


def _refused(capsys, argv, folder, *words) -> str:
    before = sorted(os.listdir(folder))
    code = cli.main(argv)
    out = capsys.readouterr()
    lines = [line for line in out.err.splitlines() if line.strip()]
    assert code == 2, out.err
    assert len(lines) == 1 and out.out == "", out.err
    assert "Traceback" not in out.err
    for word in words:
        assert word in lines[0], lines[0]
    assert sorted(os.listdir(folder)) == before  # nothing written
    return lines[0]


# --- the estimators -------------------------------------------------------------------------------------

def test_fe_estimate_grows_with_every_size():
    def gib(h=0.1, layers=2, radius=450.0, **kw):
        return fe_memory(radius, MeshSettings(element_size_mm=h), layers, **kw).bytes

    sizes = [gib(h=h) for h in (0.1, 0.07, 0.05, 0.035, 0.02)]
    assert all(a < b for a, b in zip(sizes, sizes[1:])), sizes
    layers = [gib(h=0.05, layers=k) for k in (1, 2, 4, 8)]
    assert all(a <= b for a, b in zip(layers, layers[1:])) and layers[-1] > 2 * layers[0], layers
    radii = [gib(radius=r, layers=8) for r in (60.0, 450.0, 5000.0, 1e5)]
    assert all(a <= b for a, b in zip(radii, radii[1:])) and radii[-1] > radii[0], radii
    assert gib(layers=8, film=False) < gib(layers=8) < gib(layers=8, kinematics="large")
    assert gib(layers=8) < gib(layers=8, sphere_contact="friction", flat_contact="friction")


def test_fe_sizes_count_the_model_that_is_built(model450):
    sizes = fe_sizes(450.0)
    assert sizes.face_nodes == model450.n_face
    assert sizes.body_unknowns + sizes.film_unknowns == model450.n_dofs


def test_the_reported_cases_are_estimated_as_measured():
    """The issue's report: 0.02 mm with 8 layers took 6.3 GB (R450), and with R 100000 passed 12.7 GB."""
    at450 = fe_memory(450.0, MeshSettings(element_size_mm=0.02), 8).bytes / 1e9
    assert 5.0 < at450 < 8.0
    assert fe_memory(1e5, MeshSettings(element_size_mm=0.02), 8).bytes / 1e9 > 12.7


def test_law_estimate_grows_with_pixels_laws_and_processes():
    costs = [rough_law_cost(n * n) for n in (128, 256, 512, 1024, 2048)]
    assert all(a.bytes < b.bytes and a.seconds < b.seconds for a, b in zip(costs, costs[1:]))
    one = rough_law_cost(1024**2)
    assert rough_law_cost(1024**2, film_laws=8, steel_laws=1).bytes > 8 * one.bytes * 0.9
    assert rough_law_cost(1024**2, copies=3).bytes == pytest.approx(3 * one.bytes)
    assert rough_law_cost(1024**2, steel_laws=1, film_laws=0).seconds < one.seconds


def test_map_shapes_are_read_from_headers(tmp_path):
    from PIL import Image

    Image.new("L", (300, 200)).save(tmp_path / "map.png")
    assert surface_file_shape(tmp_path / "map.png") == (200, 300)
    rows = np.arange(50 * 70, dtype=float).reshape(50, 70)
    np.savetxt(tmp_path / "heights.csv", rows, delimiter=",", fmt="%.3f")
    n, m = surface_file_shape(tmp_path / "heights.csv")
    assert m == 70 and abs(n - 50) <= 2
    x = np.arange(5000) * 0.5
    np.savetxt(tmp_path / "profile.csv", np.column_stack([x, np.sin(x)]), delimiter=",", header="x_um,z_um",
               comments="", fmt="%.4f")
    n, m = surface_file_shape(tmp_path / "profile.csv")
    assert m == PROFILE_ROWS and abs(n - 5000) <= 100
    (tmp_path / "junk.png").write_bytes(b"not an image")
    assert surface_file_shape(tmp_path / "junk.png") is None


def test_a_csv_map_near_the_cap_has_its_lines_counted(tmp_path, monkeypatch):
    """Beyond its first 64 KiB a CSV's rows are estimated from its size; near the cap they are counted."""
    from filmcal.contact import surface_files

    rng = np.random.default_rng(1)
    short, long = rng.random((1000, 10)).round(2), rng.random((1000, 10)) * 1e6  # longer lines further on
    path = tmp_path / "heights.csv"
    with open(path, "w") as fh:
        fh.write("heights\n")
        np.savetxt(fh, np.vstack([short, long]), delimiter=",", fmt="%.6g")
    estimated = surface_file_shape(path)
    assert estimated[1] == 10 and estimated[0] != 2000  # the estimate from the short first lines
    monkeypatch.setattr(surface_files, "MAX_MAP_PIXELS", 2000 * 10)
    assert surface_file_shape(path) == (2000, 10)


# --- available memory -----------------------------------------------------------------------------------

def test_available_memory_is_positive_and_at_most_the_total():
    avail, total = _memory.available_bytes(), _memory.total_bytes()
    assert avail is not None and total is not None
    assert 0 < avail <= total


@pytest.mark.parametrize("version", [1, 2])
def test_a_cgroup_limit_lowers_the_available_memory(tmp_path, monkeypatch, version):
    if version == 2:
        (tmp_path / "memory.max").write_text(f"{2 * GIB}\n")
        (tmp_path / "memory.current").write_text(f"{GIB + 300 * 2**20}\n")
        (tmp_path / "memory.stat").write_text(f"anon 1\ninactive_file {100 * 2**20}\n")
    else:
        (tmp_path / "memory.limit_in_bytes").write_text(f"{2 * GIB}\n")
        (tmp_path / "memory.usage_in_bytes").write_text(f"{GIB + 300 * 2**20}\n")
        (tmp_path / "memory.stat").write_text(f"cache 5\ntotal_inactive_file {100 * 2**20}\n")
    monkeypatch.setattr(_memory, "_cgroup_dirs", lambda: [(tmp_path, version)])
    assert _memory.cgroup_free_bytes() == GIB - 200 * 2**20
    assert _memory.available_bytes() == GIB - 200 * 2**20
    assert _memory.total_bytes() == 2 * GIB
    (tmp_path / ("memory.max" if version == 2 else "memory.limit_in_bytes")).write_text(
        "max\n" if version == 2 else "9223372036854771712\n")
    assert _memory.cgroup_free_bytes() is None


def test_check_memory_says_the_limit_and_why(small_machine):
    fits = _memory.MemoryEstimate(0.5 * GIB, "small")
    assert _memory.check_memory(fits, "--x 1", "smaller") is fits
    with pytest.raises(InputError) as err:
        _memory.check_memory(_memory.MemoryEstimate(3 * GIB, "FE: 7 unknowns", seconds=600), "--x 9", "use less")
    text = str(err.value)
    assert text.startswith("--x 9 needs about 3 GiB (FE: 7 unknowns, about 10 min of work)")
    assert "819 MiB a run may use now (80% of the 1 GiB available of 2 GiB): use less" in text
    assert "\n" not in text


# --- the commands ---------------------------------------------------------------------------------------

def test_fem_refuses_a_mesh_that_does_not_fit(capsys, tmp_path, small_machine):
    line = _refused(capsys, [*FEM, "--element-size-mm", "0.02", "--film-layers", "8", "--pressure-csv",
                             str(tmp_path / "p.csv")], tmp_path, "--element-size-mm 0.02", "--film-layers 8",
                    "GiB", "film unknowns", "available")
    assert "coarser mesh" in line


def test_fem_default_mesh_passes_on_a_small_machine(capsys, tmp_path, small_machine):
    assert cli.main([*FEM, "--json", "--pressure-csv", str(tmp_path / "p.csv")]) == 0
    assert (tmp_path / "p.csv").is_file()


def test_wheelrail_refuses_a_map_above_the_pixel_cap(capsys, tmp_path):
    from PIL import Image

    side = int(np.sqrt(MAX_MAP_PIXELS)) + 1
    Image.new("L", (side, side)).save(tmp_path / "big.png")
    line = _refused(capsys, ["wheelrail", "--offset-mm", "0", "--force-kn", "100", "--film-modulus-mpa", "2800",
                             "--wheel-roughness-map", str(tmp_path / "big.png"), "--roughness-pixel-um", "1",
                             "--roughness-height-range-um", "10"], tmp_path, "--wheel-roughness-map", "big.png",
                    f"{side} x {side}", "crop")
    assert "min" in line and "GiB" in line  # the time and memory a law on it would take


def test_wheelrail_refuses_a_map_whose_law_does_not_fit(capsys, tmp_path, small_machine):
    from PIL import Image

    Image.new("L", (2048, 2048)).save(tmp_path / "map.png")
    _refused(capsys, ["wheelrail", "--offset-mm", "0", "--force-kn", "100", "--no-film", "--rail-roughness-map",
                      str(tmp_path / "map.png"), "--roughness-pixel-um", "1", "--roughness-height-range-um", "10",
                      "--plot", str(tmp_path / "p.png")], tmp_path, "--rail-roughness-map (2048 x 2048 pixels)",
             "GiB", "boundary-element law")


def test_correct_and_curves_count_their_laws(tmp_path, small_machine):
    """correct: a law per draw; curves: a film law per draw and a steel law, which the draws share when every
    rough body is a map (each draw's own beside a synthetic surface), held by every worker."""
    from PIL import Image

    from filmcal.commands import curves
    from filmcal.commands._common import check_roughness_maps

    Image.new("L", (480, 480)).save(tmp_path / "map.png")
    args = argparse.Namespace(wheel_roughness_map=str(tmp_path / "map.png"), rail_roughness_map=None,
                              wheel_roughness_ra_um=None, rail_roughness_ra_um=None, workers=1, dask=None,
                              roughness_draws=2)
    check_roughness_maps(args, "correct", 1, 1)  # 1 + 1 laws of 0.23 Mpx: fit in 0.8 GiB
    with pytest.raises(InputError, match=r"--wheel-roughness-map \(480 x 480 pixels\) needs about .*fewer"):
        check_roughness_maps(args, "correct", 8, 1, advice="use fewer --roughness-draws")
    curves._check_map_memory(args)  # in this process: 3 laws
    args.workers = 4
    with pytest.raises(InputError, match="in each of 4 processes.*--workers"):
        curves._check_map_memory(args)
    # 520 x 520 pixels, 3 draws: 3 + 1 laws fit (0.70 GiB), 3 + 3 do not (0.89 GiB)
    Image.new("L", (520, 520)).save(tmp_path / "map.png")
    args.workers, args.roughness_draws = 1, 3
    curves._check_map_memory(args)
    args.rail_roughness_ra_um = 1.5
    with pytest.raises(InputError, match="6 boundary-element laws"):
        curves._check_map_memory(args)


def test_workers_above_four_per_core_are_refused(capsys, tmp_path):
    (tmp_path / "d.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n")
    cap = _memory.max_workers()
    line = _refused(capsys, ["campaign", "run", "--design", str(tmp_path / "d.csv"), "--store",
                             str(tmp_path / "s.sqlite"), "--workers", str(cap + 1)], tmp_path,
                    f"--workers {cap + 1}", f"at most {cap}")
    cores = _memory.cpu_count()
    assert f"{cores} core" in line
    with pytest.raises(InputError, match="threads"):
        _memory.check_workers(cap + 1, command="serve", processes=False)
    assert _memory.check_workers(cap, command="serve", processes=False) == cap


def test_workers_that_do_not_fit_in_memory_are_refused(capsys, tmp_path, small_machine):
    cap = _memory.max_workers()
    rows = "".join(f"2800,0.33,{300 + 10 * k},75\n" for k in range(cap))
    (tmp_path / "d.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n" + rows)
    _refused(capsys, ["campaign", "run", "--design", str(tmp_path / "d.csv"), "--store", str(tmp_path / "s.sqlite"),
                      "--workers", str(cap)], tmp_path, f"--workers {cap} needs about", "GiB",
             "worker processes", "use at most --workers")
    # one point: one worker process, whatever --workers says
    (tmp_path / "d.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n")
    from filmcal.commands.campaign import check_design_memory, check_fe_design
    from filmcal.campaign import read_design_csv

    check_design_memory(check_fe_design(read_design_csv(tmp_path / "d.csv")), cap)
    # every other command: its measured workers, before anything is read or written
    _refused(capsys, ["calibrate", "--film", "HS", "--workers", str(cap), "--study-dir", str(tmp_path / "study")],
             tmp_path, f"--workers {cap} needs about", "GiB")


def test_a_design_row_whose_fe_model_does_not_fit_is_refused(capsys, tmp_path, small_machine):
    (tmp_path / "d.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn,element_size_mm\n"
                                    "2800,0.33,450,75,0.1\n2800,0.33,100000,5,0.02\n")
    _refused(capsys, ["campaign", "run", "--design", str(tmp_path / "d.csv"), "--store", str(tmp_path / "s.sqlite"),
                      "--workers", "1"], tmp_path, "--design row 2", "element_size_mm 0.02", "GiB")


def test_normal_settings_pass():
    assert _memory.check_workers(2, command="campaign") == 2
    assert _memory.check_workers(None, command="pipeline") is None
    assert _memory.check_workers(1, command="curves") == 1
    default = fe_memory(450.0)
    assert _memory.check_memory(default, "--element-size-mm 0.1", "coarser") is default
    assert default.bytes < 0.5 * GIB
