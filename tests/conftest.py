"""Shared fixtures and the test tiers.

Three tiers, one suite:

- ``python3 -m pytest -m "not acceptance"`` (what ``.ci/run`` runs first): every
  test but the acceptance tier, within 15 minutes on 2 cores.
- ``python3 -m pytest -m "not slow"``: the fast tier, every stage covered,
  within about 90 s on 2 cores.
- ``python3 -m pytest -m acceptance`` (``.ci/run`` runs it last): the
  acceptance tier, :data:`ACCEPTANCE_TESTS`, tests that reproduce an
  acceptance figure end to end with many boundary-element laws, solves or
  calibrations (up to a minute each); it belongs to the slow tier too.

A test is in the slow tier when any of these holds (decided here, at
collection, so that test files need no markers):

1. it carries ``@pytest.mark.slow`` itself;
2. it uses a fixture listed in :data:`SLOW_FIXTURES` (a quick pipeline and the
   like), directly or through another fixture;
3. its source runs a pipeline: ``run_pipeline(...)``, or the command with
   ``--quick`` (string literals ``"pipeline"`` and ``"--quick"``, as in
   ``[..., "pipeline", "--quick"]``); a pipeline refusing bad input is fast;
4. its node id (relative to ``tests/``) starts with a key of
   :data:`SLOW_TESTS`: tests measured at several seconds each (MCMC runs, fine
   FE meshes, refits, process pools), with the measured time beside them.

At the end of a run the terminal summary names unmarked tests that took
longer than :data:`FAST_TEST_LIMIT_S` (candidates for :data:`SLOW_TESTS`),
and ``tests/test_tiers.py`` checks that every key still names a test and that
the fast tier keeps a test for every stage.
"""
from __future__ import annotations

import inspect
import os
import re
from pathlib import Path

import pytest

from filmcal.fem import get_model
from filmcal.study.core import RUN_STORE_VARIABLE

TESTS_DIR = Path(__file__).resolve().parent

# Each test's studies keep their runs in their own folder (also in the processes tests start): the user's
# shared cache, the default, would let one test's FE runs answer another's. The tests of that default set
# their own cache folder.
os.environ[RUN_STORE_VARIABLE] = "study"

#: Fixtures whose users are slow: a quick pipeline, or a shared setup of as
#: much work (wall time on the busy machine, as below).
SLOW_FIXTURES: frozenset[str] = frozenset({
    "quick_study",  # a quick pipeline (HS) in a subprocess: about 25 s, started at collection
    "printed",      # test_report.py: a synthetic study's report written once, 20 s
    "fine_025",     # test_fem_imprint.py: FE solves on a 0.025 mm mesh, 16 s
    "spheres",      # test_fem_reference.py: the second formulation at h = 0.1 and 0.05 mm, 20 s
})

#: Node-id prefixes (relative to tests/) of slow tests, with the time measured
#: (setup + call, wall time on 2 cores shared with other work, so about 2-3x
#: the idle time) by ``python3 -m pytest -q --durations=60 -p no:cacheprovider``.
SLOW_TESTS: dict[str, str] = {
    "test_calibration_mcmc.py::test_sampled_quantiles_agree_with_quadrature_within_their_monte_carlo_errors":
        "6.5-7.2 s: an MCMC run long enough to judge its quantiles, and the quadrature",
    "test_sheet.py::test_a_resolution_given_against_the_files_own_is_said": "6 s: four scans of the real page, each a command in a process",
    "test_sheet.py::test_the_real_sheet_scanned_with_a_noisy_sensor_reads_its_six_imprints":
        "10 s: the real page with noise added, written as PNG and read",
    "test_run_store.py::": "3-6 s each: calibrations on 32 FE runs, two of them sharing a run store",
    "test_study.py::test_a_run_is_not_refused_in_the_moment_a_brief_holder_names_itself_or_leaves":
        "6 s: 40 runs take the lock between a looping brief holder's holds",
    "test_study_heal.py::": "10-20 s each: a quick study rerun after losing a surrogate or its curves",
    "test_fuzz_datasets.py::test_data_that_cannot_be_calibrated_are_refused_before_any_work":
        "1-2 s each: the command in a process",
    "test_roughness_no_film.py::test_the_nominal_growth_follows_the_rigid_plastic_bearing_area_law":
        "6 s each: two rough Hertz solves and a boundary-element law",
    "test_rough_imprint.py::test_an_asperity_cannot_stain_a_film_whose_activation_lies_above_the_coating_hardness":
        "8 s: two boundary-element laws, one mostly plastic",
    "test_calibration_mcmc.py::test_contract_keys": "17 s: the module's default calibration",
    "test_wheelrail_cli.py::test_a_hardness_given_is_used_and_said_to_be_given":
        "7-8 s: two rough wheel-rail solves, each with its boundary-element law",
    "test_calibration_mcmc.py::test_recovers_modulus_and_sigma": "10 s: a 60-radius calibration",
    "test_calibration_mcmc.py::test_posterior_predictive_coverage": "uses the 60-radius calibration",
    "test_calibration_mcmc.py::test_same_seed_same_summary_digit_for_digit": "8 s: two samplings",
    "test_calibration_mcmc.py::test_run_is_extended_until_the_ess_target_or_the_cap": "5 s",
    "test_calibration_mcmc.py::test_backend_resume_continues_the_chain": "5 s",
    "test_campaign.py::test_failures_are_recorded_with_reasons_and_retried_on_request": "6 s",
    "test_transfer.py::test_the_transfer_term_brings_the_applied_film_to_the_calibrated_one": "5-7 s: FE and half-space at six points",
    "test_transfer.py::test_the_transfer_term_carries_over_the_films_thickness": "4-6 s: FE and half-space at six points",
    "test_transfer.py::test_a_films_band_holds_what_films_of_about_its_thickness_were_missed_by":
        "3.6 s: the shipped fit over the 26 000 rows behind it",
    "test_roughness_no_film.py::test_rough_hertz_contact_follows_greenwood_tripp": "5 s each: a rough law (BEM)",
    "test_roughness_no_film.py::test_with_elastic_asperities_the_nominal_growth_is_greenwood_and_tripps":
        "two rough laws (BEM) each",
    "test_roughness_no_film.py::test_the_nominal_area_of_rough_bodies_tends_to_the_smooth_area": "8 s: two rough laws",
    "test_correction_curves.py::test_growth_task_matches_direct_solves": "16 s: four rough laws (BEM), cold solves",
    "test_fuzz_commands.py::test_every_command_as_a_process": "5-10 s: two fuzz cases per command as processes",
    "test_study_roughness.py::test_a_study_with_roughened_flat_data_uses_its_own_draws":
        "5-10 s: sphere-on-flat growths of 5 draws (the roughness stage of a study)",
    "test_wheelrail_cli.py::test_options_rail_inclination_radius_roughness_plot": "6 s: the rough bodies' law (BEM)",
    "test_campaign.py::test_dask_cluster_gives_the_same_results_as_the_local_pool": "5 s: a Dask cluster",
    "test_campaign.py::test_killed_campaign_resumes_without_recomputing_finished_points": "4 s: kills a process",
    "test_correction_curves.py::test_bands_match_direct_solves_at_their_quantiles": "4 s",
    "test_correction_curves.py::test_a_cell_the_model_cannot_solve_is_named_as_bad_input":
        "4-5 s: wheel-rail solves and a rough law of a cell past the profiles' ends",
    "test_rough_imprint.py::test_a_higher_reading_level_reads_a_smaller_rough_imprint":
        "3-4 s: a boundary-element law and a rough sphere solve",
    "test_correction_curves.py::test_a_mixture_band_spans_the_models_it_pools": "7 s",
    "test_correction_imprint.py::test_command_rejects_bad_imprint_input": "9 s: seven processes",
    "test_correction_wheelrail.py::test_ratio_interpolates_the_film_effect_across_the_posterior": "4 s",
    "test_doe.py::test_cli_as_a_process": "5 s",
    "test_fem_inputs.py::test_cli_json_contract": "6 s: FE solves in processes",
    "test_fem_inputs.py::test_cli_bad_input_exits_2_with_one_line[args1]": "6 s",
    "test_fem_film.py::test_flat_friction_lies_between_frictionless_and_tied": "5 s",
    "test_fuzz_files.py::test_ctrl_c_of_a_running_command_exits_130_with_one_line": "5 s: interrupts a process",
    "test_fuzz_options.py::test_property_any_non_number_is_refused_naming_the_option": "5 s: many examples",
    "test_fuzz_options.py::test_option_cases_of_every_command_as_processes": "4-8 s: about 30 option cases in processes",
    "test_report.py::test_calibration_figures_name_parameters_as_an_engineer_reads_them": "8 s",
    "test_report.py::test_long_table_flows_over_pages_with_its_header_repeated": "7 s: a PDF",
    "test_report.py::test_report_of_a_non_study_exits_2": "6 s each: processes",
    "test_fem_film.py::test_mesh_convergence_with_film": "4 s: fine FE meshes",
    "test_fem_film.py::test_paper_friction_configuration_converges": "6 s: friction at both interfaces",
    "test_study.py::": "14 s shared FE campaign and surrogate, 19 s refinement",
    "test_surrogate.py::test_same_random_state_same_fit_serial_or_parallel": "8 s: parallel refits",
    "test_film_law.py::test_large_strain_sphere_on_flat_matches_the_fe": "5-10 s each: FE large-strain solves",
    "test_roughness.py::test_fully_plastic_limit_is_the_bearing_area_curve": "5 s: slow projected-gradient solves",
}

#: An unmarked test slower than this is named at the end of the run.
FAST_TEST_LIMIT_S = 3.0

#: Node-id prefixes of the acceptance tier (also slow): tests that reproduce an acceptance figure end to end
#: with many boundary-element laws, solves or calibrations, run by ``.ci/run`` after the rest, with their time.
ACCEPTANCE_TESTS: dict[str, str] = {
    "test_fem_reference.py::test_a_stiff_films_level_readings_lie_within_the_band_that_carries_the_fes_level_error":
        "50-60 s: the second formulation at two meshes on a stiff film",
    "test_transfer.py::test_the_shipped_fit_is_the_fit_of_the_shipped_rows":
        "120-190 s: the transfer fit, four residual GPs among it, made again from 25956 rows (the shipped "
        "term behind the held-out transfer figures is the fit of its rows)",
    "test_transfer.py::test_the_fit_script_reuses_every_measured_row_and_fits_them_again_to_the_same_numbers":
        "40-60 s: the transfer fit script end to end at its smallest sizes (47 FE and half-space points), three runs",
    "test_fem_edge.py::test_closing_load_edge_of_the_large_strain_film_matches_solving_again":
        "25-44 s: 26 large-strain solves (the large-strain film's closing-load edge against re-solving)",
    "test_fem_reference.py::test_production_large_strain_fe_reads_the_second_formulations_edge":
        "10-80 s each: the large-strain second formulation at two meshes (Newton at each contact set)",
    "test_fem_reference.py::test_production_fe_reads_the_second_formulations_edge":
        "11-16 s each: the second FE formulation at two meshes (the FE's default within 0.005 mm), five films",
    "test_wheelrail_cli.py::test_rough_wheel_grows_the_imprint_in_the_papers_order":
        "48 s: 12 wheel-rail solves, 3 BEM laws (the paper's film order, wheel-rail)",
    "test_roughness_sphere.py::test_rough_flat_grows_the_sphere_imprint_in_the_papers_order":
        "37 s: 3 BEM laws, 12 sphere solves (the paper's film order, sphere-on-flat)",
    "test_surface_files.py::test_wheelrail_and_correct_report_the_measured_ra_of_an_x3p_and_a_profile":
        "41 s + 30 s: boundary-element laws of a measured map and a profile in `wheelrail` and in `correct` on the "
        "quick study (Ra reported within 2 %)",
    "test_simulators.py::test_the_design_runs_the_data_cases_so_the_surrogate_is_exact_where_the_calibration_asks":
        "5 s: two toy campaigns and GP fits",
    "test_simulators.py::test_a_posterior_on_the_design_alone_is_superseded_by_one_with_the_cases_runs":
        "6 s: two toy calibrations",
    "test_simulators.py::test_a_python_simulator_of_another_law_recovers_its_own_modulus":
        "25 s: two calibrations on a lab's simulator (its own E recovered)",
    "test_simulators.py::test_the_half_space_film_model_as_a_python_simulator_recovers_its_own_modulus":
        "30 s: a calibration on the half-space film model as a lab's simulator (its own E recovered)",
    "test_simulators.py::test_a_command_simulator_fails_on_some_points_and_resumes_without_running_any_twice":
        "30 s: a calibration on an external command, killed and resumed",
    "test_simulators.py::test_the_lab_example_runs_end_to_end": "45 s: examples/lab at its fast size",
    "test_simulators.py::test_the_in_house_fe_as_an_external_command_gives_the_in_house_posterior":
        "25-60 s: two calibrations, one running `filmcal fem` as an external command 32 times",
    "test_pipeline_dask.py::": "about 2 min: two quick pipelines (one on a local Dask cluster), a killed smoke one",
    "test_dask_commands.py::test_calibrate_and_curves_on_a_local_dask_cluster_give_the_results_of_a_local_run":
        "45 s: two smoke-size calibrations and curves, one of each on a local Dask cluster",
    "test_correction_wheelrail.py::test_a_rough_correction_keeps_each_law_as_it_solves_it_and_reads_the_pipelines":
        "15-25 s: four BEM roughness laws, solved across an interrupt",
    "test_correction_wheelrail.py::test_command_with_a_rough_wheel_widens_the_band_and_reports_the_roughness_share":
        "117 s: BEM roughness laws over the conditioned draws (the roughness share of a wheel-rail band)",
    "test_fem_imprint.py::test_film_edge_matches_the_finest_mesh":
        "20 s: the FE's film edge at its finest meshes",
    "test_fem_film.py::test_a_heavily_compressed_large_strain_film_converges_under_refinement":
        "8 s: a large-strain film compressed by half its thickness at a fine mesh",
    "test_report.py::test_report_command_rewrites_from_the_study": "19 s: report of a study in a process",
    "test_calibration_options.py::":
        "30 s: a calibration with a load discrepancy (21 s) and one with a free Poisson ratio (9 s)",
    "test_calibration_model.py::test_case_intervals_on_the_fe_model_bracket_its_crossings":
        "12 s: FE solves at every case's interval ends",
    "test_roughness.py::test_law_lies_above_the_rigid_plastic_bearing_curve_and_tends_to_it":
        "12 s: three BEM laws",
    "test_wheelrail_contact.py::test_film_enlarges_the_area_at_every_offset":
        "11 s: a sweep of wheel-rail solves",
    "test_correction_outline.py::test_command_reads_an_imprint_and_writes_the_corrected_outline":
        "10 s: the outline command in a process",
    "test_pipeline.py::test_killed_pipeline_resumes_without_losing_finished_work":
        "26-75 s: a smoke pipeline killed in each stage and resumed",
    "test_pipeline.py::test_ctrl_c_in_a_parallel_stage_and_a_second_writer":
        "12-34 s: a smoke pipeline interrupted in a parallel stage, with a second writer refused",
    "test_rough_imprint.py::test_a_dataset_with_flat_ra_calibrates_stiffer_as_the_rough_law_says":
        "13-37 s: two calibrations and the rough law of a roughened flat",
    "test_domain_follows_data.py::test_a_lab_dataset_at_250_mm_is_calibrated_on_an_extended_design":
        "9-26 s: an extended design's FE runs and a calibration",
    "test_study_order.py::test_two_studies_from_empty_folders_with_one_seed_agree_to_the_last_digit":
        "30-80 s: a second quick pipeline from an empty folder",
    "test_domain_follows_data.py::test_a_known_modulus_is_recovered_from_data_at_200_to_900_mm_and_10_to_150_kN":
        "22-60 s: 14 FE imprints and a calibration on an augmented design of about 180 FE runs",
    "test_no_space.py::test_a_study_on_a_full_small_filesystem_stops_in_one_line_and_resumes_when_there_is_room":
        "40-100 s: three smoke pipelines, two on a small real filesystem",
    "test_study_trust.py::": "75-210 s: curves, report and correct on tampered, linked and read-only studies, "
                             "15 commands in processes",
}

#: Node ids kept in the fast tier although they take longer, with the reason.
FAST_BY_DESIGN: dict[str, str] = {
    "test_main_job.py::test_first_command_runs_every_stage_at_smoke_size":
        "20-40 s: the README's first command whole, so the fast tier fails wherever the main job would",
}

#: The stages the fast tier must cover: a pattern on the node id relative to
#: tests/, matching the test file's path (``test_fem_film.py``, ``fem/...``)
#: or, for the command line, also the test's name.
STAGES: dict[str, str] = {
    "doe": r"^[^:]*doe[^:]*::",
    "fem": r"^[^:]*(fem|hertz)[^:]*::",
    "campaign": r"^[^:]*campaign[^:]*::",
    "surrogate": r"^[^:]*surrogate[^:]*::",
    "calibration": r"^[^:]*calibration[^:]*::",
    "wheelrail": r"^[^:]*(wheelrail|halfspace|profile)[^:]*::",
    "correction": r"^[^:]*correction[^:]*::",
    "report": r"^[^:]*report[^:]*::",
    "cli": r"^[^:]*cli[^:]*::|::[^\[]*(cli|command)",
}

_PIPELINE_COMMAND = re.compile(r"""["']pipeline["']""")
_QUICK_OPTION = re.compile(r"""["']--quick["']""")
_PIPELINE_CALL = re.compile(r"\brun_pipeline\(")
_ALL_ITEMS = pytest.StashKey[list]()


def relative_nodeid(item: pytest.Item) -> str:
    """Node id with the path relative to ``tests/`` (``fem/test_x.py::test_y[1]``)."""
    try:
        path = Path(item.path).resolve().relative_to(TESTS_DIR).as_posix()
    except ValueError:
        return item.nodeid
    rest = item.nodeid.split("::", 1)
    return path + ("::" + rest[1] if len(rest) == 2 else "")


def key_matches(key: str, nodeid: str) -> bool:
    """Whether a :data:`SLOW_TESTS` key selects a node id (exact, parametrised or a prefix ending in ``::``)."""
    return nodeid == key or nodeid.startswith(key + "[") or nodeid.startswith(key + "::") or (
        key.endswith("::") and nodeid.startswith(key))


def _runs_the_pipeline(item: pytest.Item) -> bool:
    function = getattr(item, "function", None)
    try:
        source = inspect.getsource(function) if function is not None else ""
    except (OSError, TypeError):
        return False
    command = _PIPELINE_COMMAND.search(source) and _QUICK_OPTION.search(source)
    return bool(command or _PIPELINE_CALL.search(source))


def slow_reason(item: pytest.Item) -> str | None:
    """Why a collected test belongs to the slow tier, or None when it is fast."""
    if item.get_closest_marker("slow") is not None:
        return "marked slow"
    used = SLOW_FIXTURES.intersection(getattr(item, "fixturenames", ()))
    if used:
        return f"uses {', '.join(sorted(used))}"
    nodeid = relative_nodeid(item)
    for key, why in SLOW_TESTS.items():
        if key_matches(key, nodeid):
            return why
    if _runs_the_pipeline(item):
        return "runs the pipeline"
    return None


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark the slow tier (before ``-m`` deselects) and keep the whole collection for the tier checks."""
    for item in items:
        nodeid = relative_nodeid(item)
        for key, why in ACCEPTANCE_TESTS.items():
            if key_matches(key, nodeid):
                item.add_marker(pytest.mark.acceptance(reason=why))
                item.add_marker(pytest.mark.slow(reason=why))
        if item.get_closest_marker("slow") is None:
            reason = slow_reason(item)
            if reason is not None:
                item.add_marker(pytest.mark.slow(reason=reason))
    config.stash[_ALL_ITEMS] = list(items)


def collected_items(config: pytest.Config) -> list[pytest.Item]:
    """Every test collected in this session, before ``-m``/``-k`` deselection."""
    return config.stash.get(_ALL_ITEMS, [])


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    """Name unmarked tests slower than :data:`FAST_TEST_LIMIT_S`: candidates for :data:`SLOW_TESTS`."""
    durations: dict[str, float] = {}
    for reports in terminalreporter.stats.values():
        for report in reports:
            if getattr(report, "when", None) in ("setup", "call"):
                durations[report.nodeid] = durations.get(report.nodeid, 0.0) + report.duration
    slow_ids = {item.nodeid for item in collected_items(config) if item.get_closest_marker("slow") is not None}
    by_design = {item.nodeid for item in collected_items(config) if relative_nodeid(item) in FAST_BY_DESIGN}
    offenders = sorted(((d, n) for n, d in durations.items()
                        if d > FAST_TEST_LIMIT_S and n not in slow_ids and n not in by_design), reverse=True)
    if offenders:
        terminalreporter.section("fast tier: unmarked tests over %.0f s" % FAST_TEST_LIMIT_S)
        for duration, nodeid in offenders:
            terminalreporter.write_line(f"{duration:6.1f} s  {nodeid}  (add it to SLOW_TESTS in tests/conftest.py?)")


@pytest.fixture(scope="session")
def model450():
    """The paper-resolution model of the R450 sphere."""
    return get_model(450.0)


_QUICK_STUDY = pytest.StashKey[dict]()


def _start_quick_study(config: pytest.Config) -> dict:
    """Start the quick pipeline (HS film) through the CLI in the background, output to files."""
    import subprocess
    import sys
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="filmcal-quick-study-"))
    study = folder / "study"
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS", "--workers", "2",
           "--study-dir", str(study), "--json"]
    out, err = open(folder / "stdout", "w"), open(folder / "stderr", "w")
    started = {"folder": folder, "study": study, "cmd": cmd, "out": out, "err": err,
               "process": subprocess.Popen(cmd, stdout=out, stderr=err, stdin=subprocess.DEVNULL)}
    config.stash[_QUICK_STUDY] = started
    return started


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C as a terminal's, even when the suite was started with SIGINT ignored (``nohup ... &``, a shell's
    background job): the processes that the tests interrupt inherit the disposition, and a Python started with
    SIGINT ignored never raises KeyboardInterrupt. With this process's handler restored, they start with the
    default disposition, as from a terminal."""
    import signal
    import threading

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the quick study as soon as a selected test needs it: it then runs beside the first tests, which
    mostly use one core of two, instead of holding up the first test that asks for it."""
    if any("quick_study" in getattr(item, "fixturenames", ()) for item in session.items):
        _start_quick_study(session.config)


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Stop the quick study if no test waited for it (a run stopped early) and remove its folder."""
    import shutil

    started = session.config.stash.get(_QUICK_STUDY, None)
    if started is None:
        return
    if started["process"].poll() is None:
        started["process"].kill()
        started["process"].wait()
    started["out"].close()
    started["err"].close()
    shutil.rmtree(started["folder"], ignore_errors=True)


@pytest.fixture(scope="session")
def quick_study(request):
    """One quick pipeline run (HS film) through the CLI, started at collection: its folder, JSON summary and
    command."""
    import json

    started = request.config.stash.get(_QUICK_STUDY, None) or _start_quick_study(request.config)
    process = started["process"]
    process.wait(timeout=900)
    err = (started["folder"] / "stderr").read_text()
    assert process.returncode == 0, err[-3000:]
    return started["study"], json.loads((started["folder"] / "stdout").read_text()), started["cmd"]


@pytest.fixture
def rough_law_solves(monkeypatch):
    """The boundary-element laws solved in this process, in order (``"film_law"``, ``"steel_law"``); setting
    ``stop_at`` on the returned list (``solved.stop_at = n``) raises KeyboardInterrupt at the (n+1)-th solve, as
    Ctrl-C would."""
    from filmcal.contact.roughness import Roughness

    class Solves(list):
        stop_at = None

    solved = Solves()
    for name in ("film_law", "steel_law"):
        real = getattr(Roughness, name)

        def law(self, *args, name=name, real=real):
            if solved.stop_at is not None and len(solved) == solved.stop_at:
                raise KeyboardInterrupt
            solved.append(name)
            return real(self, *args)

        monkeypatch.setattr(Roughness, name, law)
    return solved
