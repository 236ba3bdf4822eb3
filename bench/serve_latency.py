"""The correctors served: ``filmcal serve`` driven by the ``umbridge`` Python client from other processes.

Starts ``filmcal serve`` on a finished study, then from this process (another one than the server's):

1. evaluates ``correct-sphere`` and ``correct-wheelrail`` with ``umbridge.HTTPModel`` and compares the
   outputs with what ``filmcal correct --json`` prints for the same measurements (equal to the digit);
2. times 100 sphere corrections one after another: the same sphere and load with 100 measured radii (a lab's
   replicates), and 100 different loads (each a new prediction of the radius models);
3. runs 8 client processes at once, 20 sphere corrections each, all checked against the single answer;
4. sends a malformed request, a 100 MB body, 10^6 rows and 20 clients killed mid-request, and checks that the
   server still answers and that its resident memory stayed within 50 MB of where it was.

Usage (``pip install umbridge``, in the ``bench`` extra)::

    python bench/serve_latency.py --study-dir filmcal-study [--film HS]
"""
from __future__ import annotations

import argparse
import json
import socket
import statistics
import subprocess
import sys
import time
from multiprocessing import Pool
from pathlib import Path
from urllib.parse import urlparse


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _client(job: tuple[str, str, list[float]]) -> list[list[float]]:
    import umbridge

    url, film, want = job
    model = umbridge.HTTPModel(url, "correct-sphere")
    return [model([[7.1, 450.0, 50.0]], {"film": film})[0] for _ in range(20)]


def _raw(url: str, data: bytes, read: bool = True) -> bytes:
    parts = urlparse(url)
    with socket.create_connection((parts.hostname, parts.port), timeout=30) as sock:
        try:
            sock.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            pass
        if not read:
            return b""
        try:
            return sock.recv(4096)
        except ConnectionResetError:
            return b""


def main(argv: list[str] | None = None) -> int:
    import umbridge

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study-dir", required=True)
    ap.add_argument("--film", default="HS")
    args = ap.parse_args(argv)
    cli = [sys.executable, "-m", "filmcal.cli"]
    single = {}
    for form, opts in (("sphere", ["--measured-radius-mm", "7.1", "--sphere-radius-mm", "450", "--force-kn", "50"]),
                       ("wheelrail", ["--measured-area-mm2", "150", "--offset-mm=-3", "--force-kn", "100"])):
        out = subprocess.run(cli + ["correct", "--study-dir", args.study_dir, "--film", args.film, "--json", *opts],
                             capture_output=True, text=True, check=True).stdout
        answer = json.loads(out)
        single[form] = [answer["area_mm2"], answer["area_std_mm2"], *answer["area_ci90_mm2"]]
    server = subprocess.Popen(cli + ["serve", "--study-dir", args.study_dir, "--port", "0"], stdout=subprocess.PIPE,
                              text=True)
    try:
        url = server.stdout.readline().split(" at ")[1].split()[0]
        sphere = umbridge.HTTPModel(url, "correct-sphere")
        wheel = umbridge.HTTPModel(url, "correct-wheelrail")
        got = {"sphere": sphere([[7.1, 450.0, 50.0]], {"film": args.film})[0],
               "wheelrail": wheel([[150.0, -3.0, 100.0]], {"film": args.film})[0]}
        for form in got:
            print(f"{form:9s}: served {got[form][0]:.4f} +/- {got[form][1]:.4f} mm2, filmcal correct "
                  f"{single[form][0]:.4f} +/- {single[form][1]:.4f}: {'equal' if got[form] == single[form] else 'DIFFERENT'}")
        for label, inputs in (("one sphere and load, 100 radii", [[7.0 + 0.002 * k, 450.0, 50.0] for k in range(100)]),
                              ("100 loads", [[7.1, 450.0, 45.0 + 0.1 * k] for k in range(100)])):
            times = []
            for x in inputs:
                t0 = time.perf_counter()
                sphere([x], {"film": args.film})
                times.append(time.perf_counter() - t0)
            print(f"latency, {label}: median {1e3 * statistics.median(times):.1f} ms, 90th percentile "
                  f"{1e3 * statistics.quantiles(times, n=10)[-1]:.1f} ms")
        t0 = time.perf_counter()
        with Pool(8) as pool:
            answers = pool.map(_client, [(url, args.film, single["sphere"])] * 8)
        flat = [a for batch in answers for a in batch]
        print(f"8 concurrent client processes, {len(flat)} corrections in {time.perf_counter() - t0:.2f} s: "
              f"{sum(a == single['sphere'] for a in flat)} equal to filmcal correct")
        rss0 = _rss_mb(server.pid)
        bad = _raw(url, b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: 9\r\n\r\n{not json")
        big = _raw(url, b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: 100000000\r\n\r\n" + b"0" * 1_000_000)
        rows = json.dumps({"name": "correct-sphere", "input": [[7.1, 450, 50]] * 10**6}).encode()
        many = _raw(url, f"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: {len(rows)}\r\n\r\n".encode() + rows)
        for _ in range(20):
            _raw(url, b"POST /Evaluate HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\n{\"na", read=False)
        after = sphere([[7.1, 450.0, 50.0]], {"film": args.film})[0]
        status = [reply.split(b"\r\n")[0].decode() for reply in (bad, big, many)]
        print(f"malformed: {status[0]}; 100 MB body: {status[1]}; 10^6 rows: {status[2]}; 20 clients killed "
              "mid-request; then "
              f"{'the same answer' if after == single['sphere'] else 'A DIFFERENT ANSWER'}; server memory "
              f"{rss0:.0f} -> {_rss_mb(server.pid):.0f} MB")
    finally:
        server.terminate()
        server.wait(timeout=30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
