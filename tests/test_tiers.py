"""The test tiers, the install script and the repository facts the README states."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from conftest import ACCEPTANCE_TESTS, SLOW_FIXTURES, SLOW_TESTS, STAGES, TESTS_DIR, collected_items, key_matches, relative_nodeid, slow_reason

ROOT = TESTS_DIR.parent


_COLLECTOR = """
import json, os
def pytest_collection_finish(session):
    out = [{"path": str(i.path), "nodeid": i.nodeid, "fixturenames": list(getattr(i, "fixturenames", ())),
            "slow": i.get_closest_marker("slow") is not None} for i in session.items]
    with open(os.environ["FILMCAL_COLLECTED"], "w") as fh:
        json.dump(out, fh)
"""


def _collect_whole_suite(tmp: Path) -> list[SimpleNamespace]:
    """Every test of the suite as a separate pytest process collects it (path, node id, fixtures, slow mark)."""
    import json

    (tmp / "collector_plugin.py").write_text(_COLLECTOR)
    out = tmp / "collected.json"
    env = {**os.environ, "FILMCAL_COLLECTED": str(out),
           "PYTHONPATH": os.pathsep.join([str(tmp), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "collector_plugin",
                          "-p", "no:cacheprovider", str(TESTS_DIR)], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    return [SimpleNamespace(path=d["path"], nodeid=d["nodeid"], fixturenames=d["fixturenames"],
                            get_closest_marker=(lambda m, slow=d["slow"]: object() if m == "slow" and slow else None))
            for d in json.loads(out.read_text())]


@pytest.fixture(scope="module")
def suite_items(request, tmp_path_factory) -> list:
    """The whole suite's tests: this session's collection when it spans every test file (as under the README's
    test command), else a separate collection of the whole suite."""
    items = collected_items(request.config)
    files = {p.resolve() for p in TESTS_DIR.rglob("test_*.py")}
    if files and files <= {Path(item.path).resolve() for item in items}:
        return items
    return _collect_whole_suite(tmp_path_factory.mktemp("collect"))


def test_every_slow_key_names_a_collected_test(suite_items):
    ids = [relative_nodeid(item) for item in suite_items]
    stale = [key for key in (*SLOW_TESTS, *ACCEPTANCE_TESTS) if not any(key_matches(key, nodeid) for nodeid in ids)]
    assert not stale, f"SLOW_TESTS in tests/conftest.py names tests that no longer exist: {stale}"


def test_every_slow_fixture_is_used(suite_items):
    used = {name for item in suite_items for name in getattr(item, "fixturenames", ())}
    stale = sorted(SLOW_FIXTURES - used)
    assert not stale, f"SLOW_FIXTURES in tests/conftest.py names fixtures no test uses: {stale}"


def test_fast_tier_covers_every_stage(suite_items):
    fast = [relative_nodeid(i) for i in suite_items if i.get_closest_marker("slow") is None]
    missing = [stage for stage, pattern in STAGES.items()
               if not any(re.search(pattern, nodeid, re.IGNORECASE) for nodeid in fast)]
    assert not missing, f"no fast test (pytest -m 'not slow') covers the stage(s) {missing}"
    assert len(fast) >= 100


def _item(name: str, source_function, fixtures=(), marker=None):
    """A stand-in for a collected test: what slow_reason reads."""
    return SimpleNamespace(path=TESTS_DIR / "test_example.py", nodeid=f"tests/test_example.py::{name}",
                           function=source_function, fixturenames=list(fixtures),
                           get_closest_marker=lambda m: marker if m == "slow" else None)


def _runs_quick_pipeline():
    return [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS"]


def _refuses_bad_pipeline_input():
    return [sys.executable, "-m", "filmcal.cli", "pipeline", "--workers", "0"]


def _calls_the_library():
    return run_pipeline(None)  # noqa: F821  (never called: slow_reason reads the source only)


def _plain():
    return 1 + 1


def test_slow_rules_by_marker_fixture_source_and_node_id(monkeypatch):
    assert slow_reason(_item("t", _plain, marker=object())) == "marked slow"
    assert slow_reason(_item("t", _plain, fixtures=["tmp_path", "quick_study"])) == "uses quick_study"
    assert slow_reason(_item("t", _runs_quick_pipeline)) == "runs the pipeline"
    assert slow_reason(_item("t", _calls_the_library)) == "runs the pipeline"
    assert slow_reason(_item("t", _refuses_bad_pipeline_input)) is None
    assert slow_reason(_item("t", _plain, fixtures=["tmp_path"])) is None
    monkeypatch.setitem(SLOW_TESTS, "test_example.py::t", "measured")
    monkeypatch.setitem(SLOW_TESTS, "test_example.py::Group::", "a whole class")
    assert slow_reason(_item("t", _plain)) == "measured"
    assert slow_reason(_item("t[1-a]", _plain)) == "measured"
    assert slow_reason(_item("t_other", _plain)) is None
    assert slow_reason(_item("Group::test_x", _plain)) == "a whole class"


def test_readme_first_commands_name_runnable_scripts():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    first_block = re.search(r"```bash\n(.*?)```", text, re.DOTALL).group(1).split("\n")
    assert first_block[0].startswith("scripts/in-venv filmcal pipeline")
    assert first_block[1].strip() == ".ci/run"
    for script in ("scripts/in-venv", ".ci/run"):
        path = ROOT / script
        assert path.is_file() and os.access(path, os.X_OK), script
        assert subprocess.run(["sh", "-n", str(path)]).returncode == 0, f"{script}: shell syntax"
    # the tiers the README names are the ones pytest knows
    assert 'pytest -m "not slow"' in text or "pytest -m 'not slow'" in text
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'markers\s*=\s*\[[^\]]*"slow:', pyproject)


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout")
@pytest.mark.parametrize("path", ["filmcal-study/report/report.html", "filmcal-study-quick/runs.sqlite",
                                  "examples/filmcal-study-2/x.json", ".venv/bin/python", "bench-e2e/full/x"])
def test_study_folders_and_the_venv_are_ignored_by_git(path):
    check = subprocess.run(["git", "-C", str(ROOT), "check-ignore", "-q", "--no-index", path])
    assert check.returncode == 0, f"{path} is not ignored by .gitignore"


def _in_venv(tmp_path, **env):
    return subprocess.run(["sh", str(ROOT / "scripts" / "in-venv"), "true"], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=60, cwd=tmp_path,
                          env={**os.environ, "CI": "true", **env})


def test_in_venv_refuses_a_missing_python_with_a_hint(tmp_path):
    run = _in_venv(tmp_path, PYTHON=str(tmp_path / "no-such-python3"), FILMCAL_VENV=str(tmp_path / "venv"))
    assert run.returncode == 1
    assert "no-such-python3" in run.stderr and "PYTHON" in run.stderr
    assert not (tmp_path / "venv").exists()


def test_in_venv_leaves_a_folder_that_is_not_a_venv_alone(tmp_path):
    keep = tmp_path / "work"
    keep.mkdir()
    (keep / "notes.txt").write_text("mine")
    run = _in_venv(tmp_path, PYTHON=sys.executable, FILMCAL_VENV="work")  # relative to the working directory
    assert run.returncode == 1 and "is not a virtual environment" in run.stderr
    assert (keep / "notes.txt").read_text() == "mine"


def _in_venv_made_by_scripts() -> bool:
    """Whether this test runs in a venv that scripts/in-venv made (every tier of .ci/run does)."""
    return sys.prefix != sys.base_prefix and (Path(sys.prefix) / ".filmcal-install").is_file()


@pytest.mark.skipif(not _in_venv_made_by_scripts() or shutil.which("chromium") is None
                    or shutil.which("pdftoppm") is None,
                    reason="runs .ci/run inside the venv scripts/in-venv made, with the report's system packages")
def test_ci_run_counts_no_tests_collected_as_a_failure():
    # .ci/run's README command in the venv this test runs in (each tier's own), so that nothing is installed
    env = {**os.environ, "CI": "true", "FILMCAL_VENV": sys.prefix, "PYTHON": sys.executable}
    run = subprocess.run([str(ROOT / ".ci" / "run"), "tests/test_tiers.py", "-k", "no_such_test_anywhere",
                          "-p", "no:cacheprovider"], cwd=ROOT, capture_output=True, text=True,
                         stdin=subprocess.DEVNULL, timeout=300, env=env)
    assert run.returncode == 1, run.stdout[-2000:] + run.stderr[-2000:]
    assert "no tests were collected" in run.stderr
