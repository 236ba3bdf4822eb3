"""External commands in the loop, one writer per store, kills and interrupts.

The external solver is a small stand-in script written into each test's
folder. A design column ``mode`` selects its behaviour: ``ok`` prints a JSON
object with the Hertz contact radius of the point, ``file`` writes
``outputs.json`` from a rendered input deck, ``fail`` exits with status 3
after writing to stderr, ``hang`` sleeps far past any deadline, ``garbage``
prints no JSON, ``nanout`` prints NaN. Every start is logged (point key and
pid), so that the tests can count computations and check that no process
survives.
"""
from __future__ import annotations

import csv
import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path

import pytest

from filmcal._parallel import descendant_pids
from filmcal.campaign import Campaign, CommandModel, RunStore, StoreBusyError, StoreLock, load_output_column
from filmcal.campaign.command import render_template
from test_campaign_parallel import alive, descendants

STANDIN = r'''
import argparse, json, math, os, sys, time
p = argparse.ArgumentParser()
p.add_argument("--mode"); p.add_argument("--e", type=float); p.add_argument("--r", type=float)
p.add_argument("--f", type=float); p.add_argument("--key"); p.add_argument("--log")
p.add_argument("--sleep", type=float, default=0.0); p.add_argument("--label", default="")
a = p.parse_args()
with open(a.log, "a") as log:
    log.write(f"{a.key} {os.getpid()}\n")
time.sleep(a.sleep)
# Hertz, sphere on flat of the same material (nu = 0.3): a = (3 F R / (4 E*))^(1/3)
radius = (3 * a.f * 1e3 * a.r / (4 * a.e / (2 * (1 - 0.3**2)))) ** (1 / 3)
if a.mode == "ok":
    print("solver log line 1")
    print(json.dumps({"contact_radius_mm": radius, "iterations": 7, "label": a.label, "converged": True}))
elif a.mode == "file":
    deck = open("deck.inp").read()
    e = float(deck.split("E=")[1].split()[0])
    json.dump({"contact_radius_mm": radius, "deck_modulus_mpa": e}, open("outputs.json", "w"))
elif a.mode == "fail":
    sys.stderr.write("reading deck\nERROR: element 17 distorted\n")
    sys.exit(3)
elif a.mode == "hang":
    sys.stderr.write("waiting for a licence\n"); sys.stderr.flush()
    time.sleep(600)
elif a.mode == "garbage":
    print("Segmentation fault? <html>not json</html>")
elif a.mode == "nanout":
    print('{"contact_radius_mm": NaN}')
'''
TEMPLATE = ("{python} standin.py --mode {mode} --e {modulus_mpa} --r {sphere_radius_mm} --f {force_kn} "
            "--key {key} --log {log} --sleep {sleep_s}")
DECK = "*MATERIAL\nE={modulus_mpa} NU=0.3\n*STEP R={sphere_radius_mm}\n"


def hertz_radius_mm(modulus_mpa: float, radius_mm: float, force_kn: float) -> float:
    """Hertz radius of a sphere on a flat of the same material with nu = 0.3."""
    e_star = modulus_mpa / (2.0 * (1.0 - 0.3**2))
    return (3.0 * force_kn * 1e3 * radius_mm / (4.0 * e_star)) ** (1.0 / 3.0)


def make_case(tmp_path: Path, modes: list[str], sleep_s: float = 0.3) -> dict:
    """Stand-in script, design CSV, deck template, log and the command template of one test."""
    (tmp_path / "standin.py").write_text(STANDIN)
    (tmp_path / "deck.inp.tmpl").write_text(DECK)
    log = tmp_path / "starts.log"
    rows = [{"key": f"p{i:02d}", "mode": mode, "modulus_mpa": 2000.0 + 100.0 * i, "sphere_radius_mm": 300.0 + 10 * i,
             "force_kn": 25.0 + i, "sleep_s": sleep_s, "log": str(log), "python": sys.executable}
            for i, mode in enumerate(modes)]
    design = tmp_path / "design.csv"
    with design.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    # the script lives in the test folder, each point runs in its own folder
    template = TEMPLATE.replace("standin.py", str(tmp_path / "standin.py"))
    return {"rows": rows, "design": design, "log": log, "template": template, "store": tmp_path / "runs.sqlite"}


def cli(case: dict, *extra: str) -> list[str]:
    return [sys.executable, "-m", "filmcal.cli", "campaign", "run", "--design", str(case["design"]),
            "--store", str(case["store"]), "--simulator-command", case["template"], *extra]


def starts(log: Path) -> list[tuple[str, int]]:
    if not log.exists():
        return []
    return [(key, int(pid)) for key, pid in (line.split() for line in log.read_text().splitlines() if line.strip())]


def stored(store: Path) -> dict[str, tuple[str, dict, str | None]]:
    """key -> (status, outputs, reason), read with plain sqlite3."""
    conn = sqlite3.connect(f"file:{store}?mode=ro", uri=True)
    try:
        rows = conn.execute("SELECT inputs_json, status, outputs_json, reason FROM runs").fetchall()
    finally:
        conn.close()
    return {json.loads(i)["key"]: (s, json.loads(o) if o else {}, r) for i, s, o, r in rows}


def finished_count(store: Path) -> int:
    try:
        return sum(status != "pending" for status, _, _ in stored(store).values())
    except sqlite3.Error:
        return 0


def watch_tree(root: int, stop: threading.Event, seen: set) -> None:
    """Collect every descendant of `root` until `stop` (processes come and go)."""
    while not stop.is_set():
        seen |= descendants(root)
        time.sleep(0.02)


def wait_until(predicate, timeout_s: float, process: subprocess.Popen | None = None) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process is not None:
            assert process.poll() is None, "the campaign ended before the kill"
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f"condition not met within {timeout_s} s")


def check_final_store(case: dict) -> dict:
    """Every point ends exactly once, with outputs (ok) or with the reason its mode implies."""
    rows = stored(case["store"])
    assert sorted(rows) == sorted(r["key"] for r in case["rows"])
    for row in case["rows"]:
        status, outputs, reason = rows[row["key"]]
        mode = row["mode"]
        if mode in ("ok", "file"):
            assert status == "ok", (row["key"], reason)
            expected = hertz_radius_mm(row["modulus_mpa"], row["sphere_radius_mm"], row["force_kn"])
            assert outputs["contact_radius_mm"] == pytest.approx(expected, rel=1e-12)
            assert "label" not in outputs  # strings are not outputs
        else:
            assert status == "failed", row["key"]
            assert {"fail": "exit status 3", "hang": "timeout after", "garbage": "no JSON object",
                    "nanout": "non-finite output contact_radius_mm"}[mode] in reason
            if mode == "fail":
                assert "element 17 distorted" in reason  # stderr tail
            if mode == "hang":
                assert "waiting for a licence" in reason
    return rows


MODES_20 = ["ok", "ok", "hang", "ok", "fail", "ok", "garbage", "ok", "file", "nanout",
            "ok", "hang", "ok", "fail", "ok", "garbage", "ok", "file", "ok", "ok"]


@pytest.mark.slow(reason="16-19 s: 20 commands, a kill and a rerun")
def test_twenty_points_killed_midway_and_rerun(tmp_path):
    """20 points, 2 workers, SIGKILL of the campaign midway, rerun: every point ends once, nothing survives."""
    case = make_case(tmp_path, MODES_20)
    command = cli(case, "--workers", "2", "--timeout-s", "3", "--template-file", str(tmp_path / "deck.inp.tmpl"),
                  "--json")
    seen: set = set()
    stop = threading.Event()
    with (tmp_path / "first.err").open("w") as err:
        first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=err)
        watcher = threading.Thread(target=watch_tree, args=(first.pid, stop, seen), daemon=True)
        watcher.start()
        try:
            # kill while a hanging command runs and a few points are finished
            wait_until(lambda: finished_count(case["store"]) >= 4 and "p11" in dict(starts(case["log"])), 120, first)
        finally:
            first.send_signal(signal.SIGKILL)
            first.wait(timeout=30)
            stop.set()
            watcher.join()
    assert first.returncode == -signal.SIGKILL, (tmp_path / "first.err").read_text()
    killed_at = time.monotonic()
    before = stored(case["store"])
    done_before = {key for key, (status, _, _) in before.items() if status != "pending"}
    assert 4 <= len(done_before) < 20
    first_pids = seen | {pid for _, pid in starts(case["log"])}
    assert len(seen) >= 3  # the two workers and at least one command were seen
    while any(alive(pid) for pid in first_pids) and time.monotonic() - killed_at < 5.0:
        time.sleep(0.05)
    assert not [pid for pid in first_pids if alive(pid)], "processes of the killed campaign outlived it by 5 s"

    second = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    summary = json.loads(second.stdout)
    assert summary["n_run"] == 20 - len(done_before)
    assert (summary["ok"], summary["failed"], summary["pending"]) == (13, 7, 0)
    check_final_store(case)
    counts = Counter(key for key, _ in starts(case["log"]))
    assert all(counts[key] == 1 for key in done_before)  # finished points were not recomputed
    assert set(counts) == {r["key"] for r in case["rows"]}
    # the input deck was rendered into the point's own folder
    decks = sorted((tmp_path / "runs.work").glob("*/deck.inp"))
    assert len(decks) == 20 and all("E=" in deck.read_text() for deck in decks)

    out = tmp_path / "runs.csv"
    export = subprocess.run([sys.executable, "-m", "filmcal.cli", "campaign", "export", "--store",
                             str(case["store"]), "--out", str(out)], capture_output=True, text=True, timeout=60)
    assert export.returncode == 0, export.stderr
    with out.open() as stream:
        table = list(csv.DictReader(stream))
    assert len(table) == 20
    assert {"mode", "modulus_mpa", "contact_radius_mm", "iterations", "status", "reason"} <= set(table[0])
    by_key = {row["key"]: row for row in table}
    assert by_key["p04"]["status"] == "failed" and "exit status 3" in by_key["p04"]["reason"]
    assert float(by_key["p00"]["contact_radius_mm"]) == pytest.approx(hertz_radius_mm(2000.0, 300.0, 25.0))


@pytest.mark.slow(reason="a Dask cluster, a kill and a rerun")
def test_same_on_a_dask_local_cluster_killed_and_rerun(tmp_path):
    """A few points through --command on a Dask LocalCluster, the client killed midway, then rerun."""
    distributed = pytest.importorskip("distributed")
    modes = ["ok", "hang", "ok", "fail", "garbage", "nanout", "ok", "file"]
    case = make_case(tmp_path, modes, sleep_s=0.5)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp", dashboard_address=None,
                                  scheduler_port=0) as cluster:
        command = cli(case, "--dask", cluster.scheduler_address, "--timeout-s", "8", "--template-file",
                      str(tmp_path / "deck.inp.tmpl"), "--json")
        first = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            # kill while the hanging command (p01) runs
            wait_until(lambda: finished_count(case["store"]) >= 2 and "p01" in dict(starts(case["log"])), 120, first)
        finally:
            first.send_signal(signal.SIGKILL)
            first.wait(timeout=30)
        killed_at = time.monotonic()
        done_before = {k for k, (s, _, _) in stored(case["store"]).items() if s != "pending"}
        assert 2 <= len(done_before) < len(modes)
        # the cluster cancels the killed client's tasks; their commands are killed with them
        pids = {pid for _, pid in starts(case["log"])}
        while any(alive(pid) for pid in pids) and time.monotonic() - killed_at < 5.0:
            time.sleep(0.05)
        assert not [pid for pid in pids if alive(pid)]

        second = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    summary = json.loads(second.stdout)
    assert (summary["ok"], summary["failed"], summary["pending"]) == (4, 4, 0)
    check_final_store(case)
    counts = Counter(key for key, _ in starts(case["log"]))
    assert all(counts[key] == 1 for key in done_before)


@pytest.mark.slow(reason="6 s: two campaign processes")
def test_two_campaigns_on_one_store_started_together(tmp_path):
    """The second is refused at once (exit 2, one line naming the holder); no row lost, none computed twice."""
    case = make_case(tmp_path, ["ok"] * 10, sleep_s=0.2)
    command = cli(case, "--workers", "2", "--json")
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(run.wait(timeout=300), *run.communicate()) for run in runs]
    statuses = sorted(code for code, _, _ in results)
    assert statuses == [0, 2], results
    refused = next(err for code, _, err in results if code == 2)
    assert refused.count("\n") == 1 and "Traceback" not in refused
    assert "in use by pid" in refused and "filmcal campaign run" in refused
    winner = next(json.loads(out) for code, out, _ in results if code == 0)
    assert (winner["ok"], winner["pending"], winner["n_run"]) == (10, 0, 10)
    assert Counter(key for key, _ in starts(case["log"])) == Counter({r["key"]: 1 for r in case["rows"]})
    check_final_store(case)


def test_store_lock_names_its_holder_and_is_released_by_a_killed_holder(tmp_path):
    store = tmp_path / "runs.sqlite"
    holder = subprocess.Popen([sys.executable, "-c",
                               "import sys, time; from filmcal.campaign import StoreLock; "
                               "StoreLock(sys.argv[1], 'solver run 42').acquire(); print('held', flush=True); "
                               "time.sleep(60)", str(store)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(StoreBusyError, match=rf"in use by pid {holder.pid} on .*solver run 42"):
            StoreLock(store).acquire()
        assert StoreLock(store).running_holder().pid == holder.pid
        assert StoreLock(store).running_holder().command == "solver run 42"
    finally:
        holder.kill()
        holder.wait()
    assert StoreLock(store).running_holder() is None  # its details are left behind, the lock is not
    with StoreLock(store) as lock:  # released by the OS when its holder died
        assert lock.held and lock.holder().pid == os.getpid()
        assert StoreLock(store).running_holder().pid == os.getpid()


def test_a_waiting_store_lock_is_taken_when_its_holder_ends(tmp_path):
    """With wait_s the lock waits for its holder (telling once who it is) and is taken as soon as the holder
    releases it; past wait_s it is refused as without waiting."""
    import time

    store = tmp_path / "runs.sqlite"
    holder = subprocess.Popen([sys.executable, "-c",
                               "import sys, time; from filmcal.campaign import StoreLock; "
                               "lock = StoreLock(sys.argv[1], 'study A').acquire(); print('held', flush=True); "
                               "time.sleep(1.5); lock.release(); time.sleep(60)", str(store)],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        t0 = time.monotonic()
        with pytest.raises(StoreBusyError, match="study A"):
            StoreLock(store, wait_s=0.3).acquire()
        assert 0.3 <= time.monotonic() - t0 < 1.4
        told = []
        with StoreLock(store, wait_s=30.0, on_wait=told.append) as lock:
            assert lock.held and 1.0 < time.monotonic() - t0 < 10.0
        assert len(told) == 1 and told[0].command == "study A" and told[0].pid == holder.pid
    finally:
        holder.kill()
        holder.wait()


def test_an_ok_run_is_never_downgraded(tmp_path):
    with RunStore(tmp_path / "runs.sqlite") as store:
        store.add_points({"a": {"x": 1.0}, "b": {"x": 2.0}}, "h", {"model": "m"})
        assert store.record_outcome("a", "ok", {"y": 1.0}, None, 0.1)
        assert not store.record_outcome("a", "failed", {}, "timeout after 1 s", 1.0)
        assert store.record_outcome("b", "failed", {}, "boom", 0.1)
    # a writer that bypasses the store's API is stopped by the trigger in the file itself
    conn = sqlite3.connect(tmp_path / "runs.sqlite", isolation_level=None)
    conn.execute("UPDATE runs SET status='failed', reason='later' WHERE point_id='a'")
    rows = dict(conn.execute("SELECT point_id, status FROM runs").fetchall())
    conn.close()
    assert rows == {"a": "ok", "b": "failed"}
    with RunStore(tmp_path / "runs.sqlite", readonly=True) as store:
        assert store.records(status="ok")[0].outputs == {"y": 1.0}


@pytest.mark.parametrize("content", [b"", b"just some text, not a database\n" * 20])
def test_status_of_an_empty_or_foreign_file_leaves_it_alone(tmp_path, content):
    path = tmp_path / "runs.sqlite"
    path.write_bytes(content)
    run = subprocess.run([sys.executable, "-m", "filmcal.cli", "campaign", "status", "--store", str(path), "--json"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and run.stderr.count("\n") == 1 and "Traceback" not in run.stderr
    assert "campaign store" in run.stderr
    assert path.read_bytes() == content
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs.sqlite"]


@pytest.mark.parametrize("content", [b"just some text, not a database\n" * 20, os.urandom(4096)])
def test_a_campaign_on_a_foreign_or_garbled_store_leaves_no_lock_and_no_journal(tmp_path, content):
    """The refusal came after the lock file was made: `runs.sqlite.lock` stayed beside the garbled store."""
    case = make_case(tmp_path, ["ok"], sleep_s=0.0)
    case["store"].write_bytes(content)
    before = sorted(p.name for p in tmp_path.iterdir())
    p = subprocess.run(cli(case, "--progress", "quiet"), capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "campaign store" in p.stderr, p.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before and case["store"].read_bytes() == content


def test_reading_a_finished_store_writes_nothing_beside_it(tmp_path):
    """`status` and `export` left `-wal` and `-shm` files beside a finished store (its writer left it in WAL
    mode), and a store on a read-only medium could not be read without them."""
    case = make_case(tmp_path, ["ok", "fail"], sleep_s=0.0)
    p = subprocess.run(cli(case, "--workers", "1", "--progress", "quiet"), capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    before = sorted(p.name for p in tmp_path.iterdir())
    assert not [name for name in before if name.endswith(("-wal", "-shm"))]
    conn = sqlite3.connect(case["store"])
    try:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "delete"
    finally:
        conn.close()
    for action in (["status", "--json"], ["export", "--out", str(tmp_path / "runs.csv")]):
        run = subprocess.run([sys.executable, "-m", "filmcal.cli", "campaign", action[0], "--store",
                              str(case["store"]), *action[1:]], capture_output=True, text=True, timeout=60)
        assert run.returncode == 0, run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*before, "runs.csv"])


@pytest.mark.slow(reason="4 s: process pools")
def test_workers_never_exceed_the_pending_points(tmp_path):
    from filmcal._parallel import open_executor

    with open_executor(12, n_tasks=2) as executor:
        assert executor.max_workers == 2
        wait_until(lambda: len(executor.worker_pids()) == 2, 30)
        assert len(executor.worker_pids()) == 2
    case = make_case(tmp_path, ["ok", "ok"], sleep_s=0.0)
    from filmcal._memory import max_workers  # more workers than points, within the cap of 4 per core

    run = subprocess.Popen(cli(case, "--workers", str(max_workers()), "--json"), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    seen: dict[int, str] = {}
    while run.poll() is None:
        # the campaign's own children: its workers and the resource tracker (commands are grandchildren)
        seen.update({pid: _cmdline(pid) for pid in descendant_pids(run.pid, direct=True) if pid not in seen})
        time.sleep(0.01)
    out, err = run.communicate()
    assert run.returncode == 0, err
    workers = {pid: cmd for pid, cmd in seen.items() if "resource_tracker" not in cmd}
    assert 1 <= len(workers) <= 2, workers




def _cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as stream:
            return stream.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


@pytest.mark.parametrize("address", ["garbage", "tcp://127.0.0.1", "http://x:99999"])
def test_a_bad_dask_address_fails_fast_with_one_line(tmp_path, address):
    case = make_case(tmp_path, ["ok"])
    start = time.monotonic()
    run = subprocess.run(cli(case, "--dask", address), capture_output=True, text=True, timeout=60)
    elapsed = time.monotonic() - start
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert "--dask" in run.stderr and elapsed < 10.0
    assert not case["store"].exists()


def test_a_refused_dask_address_fails_without_waiting_for_the_connect_timeout():
    """Dask's client retries a refused connection until its timeout (5 s by default): with a 120 s
    timeout, the refusal must come from the first attempt."""
    from filmcal._parallel import DaskExecutor

    start = time.monotonic()
    with pytest.raises(ValueError, match="cannot connect to the Dask scheduler at tcp://127.0.0.1:9"):
        DaskExecutor("tcp://127.0.0.1:9", connect_timeout_s=120.0)
    assert time.monotonic() - start < 60.0


def test_an_unreachable_dask_scheduler_fails_within_seconds(tmp_path):
    case = make_case(tmp_path, ["ok"])
    start = time.monotonic()
    run = subprocess.run(cli(case, "--dask", "tcp://127.0.0.1:9"), capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert "cannot connect to the Dask scheduler" in run.stderr
    assert time.monotonic() - start < 20.0
    assert not case["store"].exists()


@pytest.mark.slow(reason="4 s: a process pool")
@pytest.mark.parametrize("sigint_ignored", [False, True], ids=["sigint-default", "sigint-ignored"])
def test_ctrl_c_stops_within_two_seconds_and_keeps_finished_points(tmp_path, sigint_ignored):
    """Also when the campaign was started with SIGINT ignored (a shell's background job, `nohup ... &`): its
    worker pool must not turn the Ctrl-C into a dead worker and an internal error."""
    case = make_case(tmp_path, ["ok"] * 4 + ["hang"] * 2 + ["ok"] * 4, sleep_s=0.3)
    ignore = (lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if sigint_ignored else None
    run = subprocess.Popen(cli(case, "--workers", "2", "--timeout-s", "60", "--progress", "quiet"), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, preexec_fn=ignore)
    seen: set = set()
    wait_until(lambda: bool(seen.update(descendants(run.pid)) or True) and "p05" in dict(starts(case["log"])),
               120, run)
    seen |= descendants(run.pid)
    run.send_signal(signal.SIGINT)
    sent = time.monotonic()
    out, err = run.communicate(timeout=30)
    exit_s = time.monotonic() - sent
    assert run.returncode == 130 and err.strip().endswith("interrupted") and err.count("\n") == 1, err
    assert exit_s < 2.0, exit_s
    rows = stored(case["store"])
    assert sum(s == "ok" for s, _, _ in rows.values()) == 4  # the points before the hanging ones
    pids = seen | {pid for _, pid in starts(case["log"])}
    while any(alive(pid) for pid in pids) and time.monotonic() - sent < 2.0:
        time.sleep(0.02)
    assert not [pid for pid in pids if alive(pid)]  # within 2 s of Ctrl-C


def test_placeholders_are_shell_quoted_and_checked_before_any_work(tmp_path):
    script = tmp_path / "echo_args.py"
    script.write_text("import json, sys\nprint(json.dumps({'n_args': len(sys.argv) - 1, 'length': len(sys.argv[1])}))\n")
    label = "a b; touch pwned $(touch pwned2) 'q\""
    model = CommandModel(f"{sys.executable} {script} {{label}}", tmp_path / "work", timeout_s=30)
    outputs = model({"label": label}, point_id="p1")
    assert outputs == {"n_args": 1.0, "length": float(len(label))}
    assert not list(tmp_path.rglob("pwned*"))
    assert render_template("awk '{print $1}' {x}", {"x": 0.1}, quote=True) == "awk '{print $1}' 0.1"
    assert render_template("{x} {y} {z}", {"x": 450.0, "y": 2.5e-5, "z": True}, quote=False) == "450 2.5e-05 true"
    # a placeholder without a design column is refused before anything is written
    design = tmp_path / "design.csv"
    design.write_text("modulus_mpa\n2800\n")
    store = tmp_path / "runs.sqlite"
    run = subprocess.run([sys.executable, "-m", "filmcal.cli", "campaign", "run", "--design", str(design),
                          "--store", str(store), "--simulator-command", "solver --e {modulus_mpa} --r {sphere_radius_mm}"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "{sphere_radius_mm}" in run.stderr and run.stderr.count("\n") == 1
    assert not store.exists() and not (tmp_path / "runs.work").exists()


@pytest.mark.slow(reason="5 s: six commands and a GP fit")
def test_output_columns_of_a_store_feed_a_surrogate(tmp_path):
    case = make_case(tmp_path, ["ok", "fail", "ok", "nanout", "ok", "file"], sleep_s=0.0)
    model = CommandModel.from_files(case["template"], tmp_path / "work", [tmp_path / "deck.inp.tmpl"], timeout_s=30)
    from filmcal._parallel import SerialExecutor

    rows = [{k: v for k, v in r.items()} for r in case["rows"]]
    Campaign(model, case["store"], settings=model.settings(), executor=SerialExecutor(), group_by=()).run(
        rows, progress=False)
    column = load_output_column(case["store"], "contact_radius_mm", inputs=["modulus_mpa", "sphere_radius_mm", "force_kn"])
    assert len(column) == 4  # the ok runs only
    X = column.input_matrix()
    expected = [hertz_radius_mm(*x) for x in X]
    assert column.values == pytest.approx(expected, rel=1e-12)
    # a Gaussian-process surrogate of the command's output, fitted on the store's column
    from filmcal.surrogate import GPSurrogate

    names = ["modulus_mpa", "sphere_radius_mm", "force_kn"]
    gp = GPSurrogate(inputs=names, output="contact_radius_mm", n_restarts=1, random_state=0).fit(X, column.values)
    assert gp.predict(X) == pytest.approx(column.values, rel=1e-3)
    deck = load_output_column(case["store"], "deck_modulus_mpa")
    assert len(deck) == 1 and deck.values[0] == deck.inputs["modulus_mpa"][0]  # rendered into the deck
    with pytest.raises(ValueError, match="outputs there: contact_radius_mm"):
        load_output_column(case["store"], "area_mm2")


def test_a_template_change_makes_new_runs_and_a_rerun_recomputes_nothing(tmp_path):
    case = make_case(tmp_path, ["ok", "ok"], sleep_s=0.0)
    from filmcal._parallel import SerialExecutor

    def run(deck_text: str):
        (tmp_path / "deck.inp.tmpl").write_text(deck_text)
        model = CommandModel.from_files(case["template"], tmp_path / "work", [tmp_path / "deck.inp.tmpl"])
        return Campaign(model, case["store"], settings=model.settings(), executor=SerialExecutor(),
                        group_by=()).run(case["rows"], progress=False)

    assert run(DECK).n_run == 2
    assert run(DECK).n_run == 0
    calls = []
    (tmp_path / "deck.inp.tmpl").write_text(DECK + "*STATIC\n")
    model = CommandModel.from_files(case["template"], tmp_path / "work", [tmp_path / "deck.inp.tmpl"])
    Campaign(model, case["store"], settings=model.settings(), executor=SerialExecutor(), group_by=()).run(
        case["rows"], progress=lambda done, total: calls.append((done, total)))
    assert calls == [(1, 2), (2, 2)]
    assert run(DECK + "*OUTPUT\n").n_run == 2  # another deck is another model setting
    with RunStore(case["store"], readonly=True) as store:
        assert store.counts().total == 6 and len(store.settings_hashes()) == 3


@pytest.mark.parametrize("script, expected", [
    ("print('step 1'); print('{\"r_mm\": 2.5, \"n\": 3, \"ok\": true, \"note\": \"x\"}')", {"r_mm": 2.5, "n": 3.0, "ok": True}),
    ("print('[1, 2]')", "printed no JSON object"),
    ("print('{\"note\": \"only text\"}')", "has no numeric value"),
    ("print('{\"converged\": false, \"reason\": \"contact lost\", \"r_mm\": 1.0}')", "contact lost"),
    ("open('outputs.json', 'w').write('[]')", "outputs.json holds a list"),
    ("open('outputs.json', 'w').write('{\"r_mm\": 4.0}'); print('not json')", {"r_mm": 4.0}),
    ("import os, signal; os.kill(os.getpid(), signal.SIGKILL)", "killed by signal 9"),
    ("import sys; sys.stderr.write('\\n'.join(f'line {i}' for i in range(50))); sys.exit(1)",
     "exit status 1); stderr: line 45 | line 46 | line 47 | line 48 | line 49"),
])
def test_command_outputs_and_failure_reasons(tmp_path, script, expected):
    from filmcal._parallel import SerialExecutor

    (tmp_path / "model.py").write_text(script + "\n")
    model = CommandModel(f"{sys.executable} {tmp_path / 'model.py'} {{x}}", tmp_path / "work", timeout_s=30)
    Campaign(model, tmp_path / "runs.sqlite", settings=model.settings(), executor=SerialExecutor(),
             group_by=()).run([{"x": 1.0}], progress=False)
    with RunStore(tmp_path / "runs.sqlite", readonly=True) as store:
        (record,) = store.records()
    if isinstance(expected, dict):
        assert (record.status, record.outputs) == ("ok", expected)
    else:
        assert record.status == "failed" and expected in record.reason, record.reason


def test_retry_reruns_failed_points_only_and_keeps_ok_ones(tmp_path):
    from filmcal._parallel import SerialExecutor

    case = make_case(tmp_path, ["ok", "fail", "garbage"], sleep_s=0.0)
    model = CommandModel(case["template"], tmp_path / "work", timeout_s=30)

    def run(retry: bool):
        return Campaign(model, case["store"], settings=model.settings(), executor=SerialExecutor(),
                        group_by=()).run(case["rows"], retry_failed=retry, progress=False)

    assert (run(False).n_run, run(False).n_run, run(True).n_run) == (3, 0, 2)
    with RunStore(case["store"], readonly=True) as store:
        attempts = {r.inputs["key"]: (r.status, r.attempts) for r in store.records()}
    assert attempts == {"p00": ("ok", 1), "p01": ("failed", 2), "p02": ("failed", 2)}
    assert Counter(key for key, _ in starts(case["log"])) == {"p00": 1, "p01": 2, "p02": 2}


@pytest.mark.parametrize("extra, message", [
    (["--template-file", "deck.inp.tmpl"], "--template-file needs --simulator-command"),
    (["--simulator-command", "echo {x}", "--template-file", "missing.tmpl"], "--template-file 'missing.tmpl' does not exist"),
    (["--simulator-command", "echo {x}", "--template-file", "a/deck.inp", "--template-file", "b/deck.inp.tmpl"],
     "render to the same name"),
    (["--simulator-command", "echo {x}", "--simulator-python", "os:getcwd"], "not allowed with argument"),
    (["--simulator-command", "   "], "--simulator-command must be a non-empty command template"),
])
def test_command_options_are_checked_before_anything_is_written(tmp_path, monkeypatch, capsys, extra, message):
    from filmcal.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.csv").write_text("x\n1\n")
    (tmp_path / "deck.inp.tmpl").write_text("X={x}\n")
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
    (tmp_path / "a" / "deck.inp").write_text("X={x}\n")
    (tmp_path / "b" / "deck.inp.tmpl").write_text("X={x}\n")
    try:
        status = main(["campaign", "run", "--design", "d.csv", "--store", "runs.sqlite", *extra])
    except SystemExit as exc:
        status = exc.code
    err = capsys.readouterr().err
    assert status == 2 and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "runs.sqlite").exists() and not (tmp_path / "runs.work").exists()


def test_a_linked_point_folder_is_unlinked_not_followed(tmp_path):
    """--retry-failed empties a point's folder: a symbolic link in its place must go, not its target."""
    from filmcal.campaign import CommandModel

    keep = tmp_path / "precious"
    keep.mkdir()
    (keep / "data.txt").write_text("mine")
    work = tmp_path / "work"
    work.mkdir()
    (work / "p1").symlink_to(keep, target_is_directory=True)
    model = CommandModel("echo '{\"contact_radius_mm\": 1.5}'", work)
    out = model({"x": 1.0}, point_id="p1")
    assert out["contact_radius_mm"] == 1.5
    assert (keep / "data.txt").read_text() == "mine" and not (work / "p1").is_symlink()


def test_a_store_reached_through_a_link_takes_the_same_lock(tmp_path):
    from filmcal.campaign.lock import lock_path_for

    store = tmp_path / "runs.sqlite"
    store.touch()
    link = tmp_path / "alias.sqlite"
    link.symlink_to(store)
    assert lock_path_for(link) == lock_path_for(store) == tmp_path / "runs.sqlite.lock"


def test_a_store_reached_through_a_hard_link_is_refused_while_held(tmp_path):
    """Two names of one file (a hard link: another lock file's name) still take one lock, on the store's inode;
    released, the other name takes it."""
    import sqlite3

    from filmcal.campaign.lock import StoreBusyError, StoreLock

    store = tmp_path / "runs.sqlite"
    sqlite3.connect(store).close()
    (tmp_path / "other").mkdir()
    twin = tmp_path / "other" / "twin.sqlite"
    os.link(store, twin)
    with StoreLock(store, "first"):
        with pytest.raises(StoreBusyError, match="is in use"):
            StoreLock(twin, "second").acquire()
        with sqlite3.connect(twin) as db:  # SQLite's own locks are not flock's: the store stays usable
            db.execute("create table if not exists t (x)")
    with StoreLock(twin, "second"):
        with pytest.raises(StoreBusyError, match="under another name of the same file"):
            StoreLock(store, "first").acquire()


def test_a_design_row_with_fewer_cells_than_columns_is_refused_before_any_run(tmp_path):
    """`850,0.33,7.5` under four column names ran with force_kn silently left out."""
    case = make_case(tmp_path, ["ok"], sleep_s=0.0)
    lines = case["design"].read_text().splitlines()
    case["design"].write_text("\n".join([lines[0], lines[1].rsplit(",", 1)[0]]) + "\n")
    p = subprocess.run(cli(case), capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "line 2: 7 cells for 8 columns" in p.stderr
    assert not case["store"].exists() and starts(case["log"]) == []


def test_a_campaign_whose_every_point_failed_exits_1_and_names_the_first_reason(tmp_path):
    """All points failed used to exit 0 like a good run; one ok point among failures is a normal run."""
    case = make_case(tmp_path, ["fail", "garbage"], sleep_s=0.0)
    p = subprocess.run(cli(case, "--workers", "1", "--progress", "quiet"), capture_output=True, text=True)
    assert p.returncode == 1, p.stderr
    assert p.stdout.startswith("2 points: 0 ok, 2 failed")
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and "every point failed" in err[0] and "--retry-failed" in err[0]
    assert "exit status 3" in err[0] or "no JSON object" in err[0]
    mixed = make_case(tmp_path / "mixed" if (tmp_path / "mixed").mkdir() is None else None, ["fail", "ok"], 0.0)
    p = subprocess.run(cli(mixed, "--workers", "1", "--progress", "quiet"), capture_output=True, text=True)
    assert p.returncode == 0 and p.stderr == "", p.stderr


def test_progress_log_prints_a_line_per_finished_point_with_the_time_left(tmp_path):
    """`--progress log` printed nothing at all: the campaign's own bar shows only on a terminal."""
    case = make_case(tmp_path, ["ok", "ok", "ok"], sleep_s=0.0)
    p = subprocess.run(cli(case, "--workers", "1", "--progress", "log"), capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    lines = p.stderr.strip().splitlines()  # the first, then at most one a second, and always the last
    assert lines[0].startswith("[campaign] 1/3 done") and "left" in lines[0]
    assert lines[-1].startswith("[campaign] 3/3 done") and "left" not in lines[-1]
    quiet = subprocess.run(cli(case, "--workers", "1", "--progress", "quiet", "--retry-failed"),
                           capture_output=True, text=True)
    assert quiet.returncode == 0 and quiet.stderr == ""
