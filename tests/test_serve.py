"""`filmcal serve`: the UM-Bridge protocol over HTTP, the numbers `filmcal correct` prints, bounds and abuse.

The requests are made as the protocol defines them (the calls the `umbridge` Python client makes, written
with the standard library here; `bench/serve_latency.py` drives the `umbridge` client itself).
"""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from urllib.parse import urlparse

import pytest


def _call(url: str, route: str, body: dict | bytes | None = None, method: str = "POST") -> tuple[int, dict]:
    data = body if isinstance(body, bytes) or body is None else json.dumps(body).encode()
    request = urllib.request.Request(url + route, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=60) as response:
            return response.status, json.loads(response.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def _rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def _files(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in folder.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def server(quick_study):
    study, _, _ = quick_study
    cli = [sys.executable, "-m", "filmcal.cli"]
    # the answers `filmcal correct` prints, first: it may keep its solves in the study; the server never writes
    single = {}
    for form, args in (("sphere", ["--measured-radius-mm", "7.1", "--sphere-radius-mm", "450", "--force-kn", "50"]),
                       ("wheelrail", ["--measured-area-mm2", "150", "--offset-mm=-3", "--force-kn", "100",
                                      "--offset-std-mm", "1"])):
        p = subprocess.run(cli + ["correct", "--study-dir", str(study), "--film", "HS", "--json", *args],
                           capture_output=True, text=True, check=True)
        single[form] = json.loads(p.stdout)
    before = _files(study)
    process = subprocess.Popen(cli + ["serve", "--study-dir", str(study), "--port", "0", "--request-timeout-s", "60"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = process.stdout.readline()
    assert line.startswith("serving correct-sphere, correct-wheelrail"), line + process.stderr.read()
    url = line.split(" at ")[1].split()[0]
    yield url, process, single
    process.terminate()
    process.wait(timeout=30)
    assert _files(study) == before, "the server wrote into the study"


def test_the_protocol_answers_with_the_numbers_filmcal_correct_prints(server):
    url, _, single = server
    status, info = _call(url, "/Info", method="GET")
    assert status == 200 and info == {"protocolVersion": 1.0, "models": ["correct-sphere", "correct-wheelrail"]}
    for name in info["models"]:
        assert _call(url, "/ModelInfo", {"name": name})[1]["support"] == {
            "Evaluate": True, "Gradient": False, "ApplyJacobian": False, "ApplyHessian": False}
        assert _call(url, "/InputSizes", {"name": name, "config": {}})[1] == {"inputSizes": [3]}
        assert _call(url, "/OutputSizes", {"name": name, "config": {}})[1] == {"outputSizes": [4]}
    requests = {"sphere": {"name": "correct-sphere", "input": [[7.1, 450, 50]], "config": {"film": "HS"}},
                "wheelrail": {"name": "correct-wheelrail", "input": [[150, -3, 100]],
                              "config": {"film": "HS", "offset_std_mm": 1}}}
    for form, request in requests.items():
        status, answer = _call(url, "/Evaluate", request)
        assert status == 200, answer
        want = single[form]
        assert answer["output"] == [[want["area_mm2"], want["area_std_mm2"], *want["area_ci90_mm2"]]]
        assert answer["config"]["film"] == "HS" and answer["config"]["imprint_model"] == "mixture"
        assert answer["provenance"]["posteriors"] == want["provenance"]["posteriors"]
        # the study's results as the server read them: the same as a correction's (the caches aside)
        assert answer["provenance"]["manifest_sha256"] == want["provenance"]["manifest_sha256"]
    assert answer["patch"]["length_mm"] == single["wheelrail"]["patch"]["length_mm"]


def test_the_old_name_of_the_measured_areas_uncertainty_is_read_with_a_warning(server):
    url = server[0]
    new = {"name": "correct-wheelrail", "input": [[150, -3, 100]],
           "config": {"film": "HS", "offset_std_mm": 1, "measured_area_std_mm2": 3}}
    old = {**new, "config": {"film": "HS", "offset_std_mm": 1, "measurement_std_mm2": 3}}
    (s_new, a_new), (s_old, a_old) = _call(url, "/Evaluate", new), _call(url, "/Evaluate", old)
    assert s_new == s_old == 200, (a_new, a_old)
    assert a_old["output"] == a_new["output"] and a_old["config"] == a_new["config"]
    assert any("measurement_std_mm2 is renamed measured_area_std_mm2" in w for w in a_old["warnings"])
    assert not any("renamed" in w for w in a_new.get("warnings", []))


def test_eight_concurrent_clients_get_the_same_answers(server):
    url, _, single = server
    want = [single["sphere"]["area_mm2"], single["sphere"]["area_std_mm2"], *single["sphere"]["area_ci90_mm2"]]
    answers, errors = [], []

    def client():
        try:
            for _ in range(5):
                answers.append(_call(url, "/Evaluate", {"name": "correct-sphere", "input": [[7.1, 450, 50]],
                                                        "config": {"film": "HS"}})[1]["output"][0])
        except Exception as exc:  # noqa: BLE001 (collected and asserted below)
            errors.append(exc)

    threads = [threading.Thread(target=client) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not errors and len(answers) == 40
    assert all(a == want for a in answers)


@pytest.mark.parametrize("body,kind,words", [
    (b"{not json", "InvalidInput", "not JSON"),
    (b"[" * 5_000 + b"]" * 5_000, "InvalidInput", "JSON"),  # deep nesting within the size bound
    ({"name": "nope", "input": [[1, 2, 3]]}, "ModelNotFound", "correct-sphere"),
    ({"name": "correct-sphere", "input": [[7.1, 450]], "config": {"film": "HS"}}, "InvalidInput", "length 2"),
    ({"name": "correct-sphere", "input": [[7.1, 450, 50], [1, 2, 3]], "config": {"film": "HS"}}, "InvalidInput",
     "one vector"),
    ({"name": "correct-sphere", "input": [[7.1, "450", 50]], "config": {"film": "HS"}}, "InvalidInput", "number"),
    ({"name": "correct-sphere", "input": [[7.1, 450, 50]], "config": {}}, "InvalidInput", "film"),
    ({"name": "correct-sphere", "input": [[7.1, 450, 50]], "config": {"film": "HS", "filmm": 1}}, "InvalidInput",
     "'filmm'"),
    ({"name": "correct-sphere", "input": [[7.1, 450, 50]], "config": {"film": "XX"}}, "InvalidInput", "XX"),
    ({"name": "correct-sphere", "input": [[71, 450, 50]], "config": {"film": "HS"}}, "InvalidInput", "implausible"),
    # unknown choices were answered as 'no posterior ... run calibrate'
    ({"name": "correct-wheelrail", "input": [[150, -3, 100]], "config": {"film": "HS", "kinematics": "medium"}},
     "InvalidInput", "kinematics must be one of small, large"),
    ({"name": "correct-wheelrail", "input": [[150, -3, 100]], "config": {"film": "HS", "imprint_model": "bogus"}},
     "InvalidInput", "imprint_model must be one of edge, activation, capsule, mixture"),
    ({"name": "correct-wheelrail", "input": [[150, -3, 1e9]], "config": {"film": "HS"}}, "InvalidInput", "force"),
    # an integer of 400 digits has no float: it was an InternalError (500, OverflowError)
    (b'{"name": "correct-sphere", "input": [[7.1, 1' + b"0" * 400 + b', 50]], "config": {"film": "HS"}}',
     "InvalidInput", "finite number"),
])
def test_bad_requests_get_the_protocols_error_objects(server, body, kind, words):
    url, _, _ = server
    status, answer = _call(url, "/Evaluate", body)
    assert status >= 400 and answer["error"]["type"] == kind, answer
    assert words in answer["error"]["message"]


@pytest.mark.parametrize("method", ["DELETE", "PUT", "PATCH", "OPTIONS"])
def test_other_methods_get_a_json_error_object_not_an_html_page(server, method):
    """`DELETE /Info` was answered by http.server's own HTML page (501, text/html)."""
    url, _, _ = server
    status, answer = _call(url, "/Info", b"{}", method=method)
    assert status == 501 and answer["error"]["type"] == "UnsupportedFeature", answer
    assert method in answer["error"]["message"] and "GET /Info" in answer["error"]["message"]
    assert _call(url, "/Info", method="GET")[0] == 200  # and the server goes on
    assert _call(url, "/Info/?client=x", method="GET")[0] == 200  # a query string is not part of the route


def _raw(url: str, data: bytes, read: bool = True) -> bytes:
    """Send bytes as they are (a server may answer and close before it has them all); return the reply."""
    parts = urlparse(url)
    with socket.create_connection((parts.hostname, parts.port), timeout=30) as sock:
        try:
            sock.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            pass
        if not read:
            return b""
        chunks = []
        while True:
            try:
                chunk = sock.recv(65536)
            except ConnectionResetError:
                break
            if not chunk:
                break
            chunks.append(chunk)
        return b"".join(chunks)


def test_oversized_and_abandoned_requests_cost_nothing_and_the_server_goes_on(server):
    url, process, single = server
    rss = _rss_kb(process.pid)
    t0 = time.perf_counter()
    # a 100 MB body announced: refused from its length, before it is read
    head = b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100000000\r\n\r\n"
    reply = _raw(url, head + b'{"name": "correct-sphere", "input": [[')
    assert reply.startswith(b"HTTP/1.1 413") and b"at most" in reply
    assert time.perf_counter() - t0 < 5
    # 10^6 rows sent for real (20 MB): refused by size
    rows = json.dumps({"name": "correct-sphere", "input": [[7.1, 450, 50]] * 10**6, "config": {"film": "HS"}})
    head = f"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: {len(rows)}\r\n\r\n".encode()
    reply = _raw(url, head + rows.encode())
    assert reply.startswith(b"HTTP/1.1 413") and b"InvalidInput" in reply
    # chunked bodies are not taken
    reply = _raw(url, b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\n")
    assert reply.startswith(b"HTTP/1.1 411")
    # clients killed mid-request: half a body, then gone
    for _ in range(20):
        _raw(url, b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\n{\"name\": ", read=False)
    status, answer = _call(url, "/Evaluate", {"name": "correct-sphere", "input": [[7.1, 450, 50]],
                                              "config": {"film": "HS"}})
    assert status == 200 and answer["output"][0][0] == single["sphere"]["area_mm2"]
    assert process.poll() is None
    assert _rss_kb(process.pid) - rss < 50_000  # kB: none of it was held


def test_serving_beyond_this_machine_says_the_protocol_has_no_authentication(quick_study):
    study, _, _ = quick_study
    process = subprocess.Popen([sys.executable, "-m", "filmcal.cli", "serve", "--study-dir", str(study), "--host",
                                "0.0.0.0", "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        line = process.stdout.readline()
        assert "serving" in line
        warning = process.stderr.readline()
        assert "no authentication" in warning
    finally:
        process.terminate()
        process.wait(timeout=30)


def test_an_address_it_cannot_listen_on_is_refused_in_one_line(quick_study, tmp_path):
    study, _, _ = quick_study
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    try:
        for host, port in (("999.1.1.1", "0"), ("127.0.0.1", str(busy.getsockname()[1]))):
            p = subprocess.run([sys.executable, "-m", "filmcal.cli", "serve", "--study-dir", str(study), "--host", host,
                                "--port", port], capture_output=True, text=True, timeout=60)
            assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
            assert f"--host {host} --port {port}: cannot listen there" in p.stderr
    finally:
        busy.close()


def test_an_empty_address_is_refused_not_read_as_every_interface(tmp_path, capsys):
    """``--host ""`` (an unset shell variable) would listen on every interface of a server without
    authentication: refused in one line before the study is read."""
    from filmcal.cli import main

    assert main(["serve", "--study-dir", str(tmp_path), "--host", " ", "--port", "0"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--host must be an address" in err
