"""The pipeline's shared worker pool and the allocator setting of its processes."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from filmcal._parallel import SharedPool, descendant_pids, keep_freed_memory, run_tasks


def _pid(_: int) -> int:
    return os.getpid()


def _warn(k: int) -> int:
    import warnings

    warnings.warn(f"fit {k} did not converge", RuntimeWarning, stacklevel=1)
    return k


def test_a_workers_warnings_come_back_to_the_caller_not_to_the_terminal(capfd):
    """A library warning raised in a worker travels back with the value and is raised again in the caller,
    where a stage collects it (one line), instead of reaching stderr raw from the worker process."""
    import warnings

    with SharedPool(2) as pool, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        done: dict = {}
        run_tasks({k: (_warn, (k,)) for k in range(4)}, pool, lambda key, value, n: done.__setitem__(key, value))
    assert done == {k: k for k in range(4)}
    assert sorted(str(w.message) for w in caught) == [f"fit {k} did not converge" for k in range(4)]
    assert all(w.category is RuntimeWarning for w in caught)
    assert "did not converge" not in capfd.readouterr().err


def test_shared_pool_starts_its_workers_with_the_first_task_only():
    before = descendant_pids(os.getpid(), direct=True)
    with SharedPool(2) as pool:
        run_tasks({}, pool, lambda *a: None)  # nothing to do: nothing started
        assert not pool.started and descendant_pids(os.getpid(), direct=True) == before
        run_tasks({0: (_pid, (0,))}, pool, lambda *a: None)
        assert pool.started and len(descendant_pids(os.getpid(), direct=True) - before) >= 2  # (and a resource tracker)


def test_every_stage_runs_in_the_same_worker_processes():
    seen: list[set[int]] = []
    with SharedPool(2) as pool:
        for stage in range(3):
            pids: set[int] = set()
            run_tasks({k: (_pid, (k,)) for k in range(6)}, pool, lambda key, pid, k: pids.add(pid))
            seen.append(pids)
            assert pool.started
        workers = descendant_pids(os.getpid(), direct=True)
    assert os.getpid() not in set().union(*seen)
    assert set().union(*seen) <= workers and len(set().union(*seen)) <= 2
    with pytest.raises(RuntimeError, match="shut down"):
        pool.submit(_pid, 0)


def test_a_failed_task_in_the_shared_pool_raises_and_leaves_the_pool_usable():
    with SharedPool(2) as pool:
        with pytest.raises(RuntimeError, match="1 task"):
            run_tasks({"bad": (int, ("x",)), "good": (int, ("3",))}, pool, lambda *a: None)
        got = {}
        run_tasks({"again": (int, ("4",))}, pool, lambda key, value, k: got.update({key: value}))
    assert got == {"again": 4}


def test_workers_must_be_a_positive_integer():
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="workers"):
            SharedPool(bad)


_FAULTS = textwrap.dedent("""
    import resource, sys
    import numpy as np
    import scipy.fft as fft
    if sys.argv[1] == "keep":
        from filmcal._parallel import keep_freed_memory
        assert keep_freed_memory()
    x = np.random.default_rng(0).random((256, 256))
    kernel = np.ones((256, 129))
    fft.irfft2(fft.rfft2(x) * kernel, s=x.shape)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(200):  # the pattern of an FFT contact iteration: temporaries of 0.25-0.5 MB
        y = fft.irfft2(fft.rfft2(x) * kernel, s=x.shape)
        z = y - x
        w = (z > 0) & (y < 1)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_kept_freed_memory_spares_the_page_faults_of_repeated_temporaries():
    def faults(mode: str) -> int:
        run = subprocess.run([sys.executable, "-c", _FAULTS, mode], capture_output=True, text=True, check=True,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
        return int(run.stdout.strip())

    assert keep_freed_memory()
    default, kept = faults("default"), faults("keep")
    # by default every iteration faults its temporaries in again (about 128 pages per 0.5 MB array)
    assert default > 10_000 and kept < default / 10


def _flaky_start_pool(failures: int):
    """A one-worker pool whose first `failures` workers exit with 255 before they are ready (an exec refused)."""
    from filmcal._parallel.pool import LocalPoolExecutor, _Worker

    class FlakyStart(LocalPoolExecutor):
        def _start_worker(self):
            if self.failures_left > 0:
                self.failures_left -= 1
                parent_conn, child_conn = self._context.Pipe(duplex=True)
                process = self._context.Process(target=os._exit, args=(255,), daemon=True)
                process.start()
                child_conn.close()
                return _Worker(process, parent_conn)
            return super()._start_worker()

    FlakyStart.failures_left = failures  # read by the manager thread that __init__ starts
    return FlakyStart(1)


def test_a_worker_that_fails_to_start_once_is_started_again():
    import math

    with _flaky_start_pool(1) as pool:
        assert pool.submit(math.sqrt, 4.0).result(timeout=60) == 2.0


def test_workers_that_keep_failing_to_start_stop_the_pool():
    import math

    with _flaky_start_pool(10) as pool:
        with pytest.raises(RuntimeError, match="failed to start 3 times in a row"):
            pool.submit(math.sqrt, 4.0).result(timeout=60)
