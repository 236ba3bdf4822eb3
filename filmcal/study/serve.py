"""A study's correctors served over HTTP by the UM-Bridge protocol (1.0): ``filmcal serve``.

Any UM-Bridge client (the ``umbridge`` packages for Python, C++, MATLAB and R; a plain HTTP POST of JSON)
evaluates two models:

``correct-sphere``
    input ``[[measured_radius_mm, sphere_radius_mm, force_kn]]``
``correct-wheelrail``
    input ``[[measured_area_mm2, offset_mm, force_kn]]``

both with output ``[[area_mm2, area_std_mm2, area_ci90_low_mm2, area_ci90_high_mm2]]`` (`OUTPUT_NAMES`), the
answer `filmcal correct` prints for the same measurement (`correct_measurement`, the same rules). The film
and the options go in the request's ``config`` (`CONFIG_KEYS`; ``film`` is required, an unknown key is an
error, not ignored). Beside ``output`` an answer carries ``config`` (the options used, defaults filled in),
``provenance`` (the study's manifest and posteriors by SHA-256, the filmcal version), ``patch`` and
``warnings`` when it has them: the protocol's clients read ``output`` and ignore the rest.

What one request may cost is bounded before the work: the body (`MAX_BODY_BYTES`, from its declared length,
before it is read; no chunked bodies), one input vector of the model's size, the connections served at once
(`MAX_CONNECTIONS`; more are answered "busy"), a client's silence (`CLIENT_TIMEOUT_S`; a client killed
mid-request frees its thread then) and the time an answer may take (``request_timeout_s``: past it the
request is answered with an error while the solve goes on, so that the next request at that offset and load
reads it). Corrections of one film with one set of options run one at a time (their correctors are built
once and shared), others in parallel on ``workers`` threads. A bad request is answered with the protocol's
error object (``{"error": {"type", "message"}}``, HTTP 400): ``InvalidInput``, ``ModelNotFound``,
``UnsupportedFeature``; a failure of the server itself with ``InternalError`` (HTTP 500), which is a bug.

The study is opened read-only: the server never writes it.
"""
from __future__ import annotations

import json
import math
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

__all__ = ["CorrectionServer", "MODELS", "OUTPUT_NAMES", "CONFIG_KEYS", "PROTOCOL_VERSION", "MAX_BODY_BYTES",
           "MAX_CONNECTIONS"]

PROTOCOL_VERSION = 1.0
#: Each model's input names, in the order of its one input vector.
MODELS = {"correct-sphere": ("measured_radius_mm", "sphere_radius_mm", "force_kn"),
          "correct-wheelrail": ("measured_area_mm2", "offset_mm", "force_kn")}
#: The output vector's entries.
OUTPUT_NAMES = ("area_mm2", "area_std_mm2", "area_ci90_low_mm2", "area_ci90_high_mm2")
#: The keys a request's config may hold (vocabulary names), and which model takes each.
CONFIG_KEYS = {"film": "both", "imprint_model": "both", "kinematics": "both", "calibration_forces_kn": "both",
               "seed": "both", "elastic_limit_mpa": "both", "measurement_std_mm": "correct-sphere",
               "measured_area_std_mm2": "correct-wheelrail", "offset_std_mm": "correct-wheelrail",
               "wheel_roughness_ra_um": "correct-wheelrail", "rail_roughness_ra_um": "correct-wheelrail"}
#: Old config keys read for one release (the answer's warnings name the new one).
RENAMED_CONFIG_KEYS = {"measurement_std_mm2": "measured_area_std_mm2"}
#: Largest request body (bytes): a request is a few hundred bytes.
MAX_BODY_BYTES = 64 * 1024
#: Connections served at once; more are answered "busy" (HTTP 503) at once.
MAX_CONNECTIONS = 64
#: Seconds a client may stay silent while sending its request.
CLIENT_TIMEOUT_S = 30.0


class _RequestError(Exception):
    """A request the protocol answers with an error object."""

    def __init__(self, kind: str, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.kind, self.status = kind, status


def _number(name: str, value: Any, low: float | None = None, high: float | None = None) -> float:
    try:  # an integer of hundreds of digits has no float: OverflowError
        number = float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
    except OverflowError:
        number = math.nan
    if not math.isfinite(number):
        shown = repr(value) if len(repr(value)) <= 40 else f"{repr(value)[:20]}... ({len(repr(value))} characters)"
        raise _RequestError("InvalidInput", f"{name} must be a finite number, got {shown}")
    value = number
    if (low is not None and value < low) or (high is not None and value > high):
        raise _RequestError("InvalidInput", f"{name} {value:g} outside [{low:g}, {high:g}]")
    return value


class CorrectionServer:
    """The study's correctors behind a UM-Bridge HTTP server.

    Parameters
    ----------
    study_dir : str or Path
        A finished study (opened read-only).
    host : str
        Address to bind: 127.0.0.1 (this machine only) unless told otherwise.
    port : int
        0 picks a free port (`port` then says which).
    workers : int
        Threads that run corrections.
    request_timeout_s : float
        Longest wait for one answer.
    """

    def __init__(self, study_dir, *, host: str = "127.0.0.1", port: int = 4242, workers: int = 2,
                 request_timeout_s: float = 120.0) -> None:
        from filmcal._errors import InputError
        from filmcal.study import Study
        from filmcal.study.correct import CorrectionWarning

        self.study = Study(study_dir, read_only=True)
        self.request_timeout_s = float(request_timeout_s)
        self._pool = ThreadPoolExecutor(max_workers=int(workers), thread_name_prefix="filmcal-serve")
        self._cache: dict = {}
        self._locks: dict[tuple, threading.Lock] = {}
        self._guard = threading.Lock()
        self._slots = threading.BoundedSemaphore(MAX_CONNECTIONS)
        self._pending = threading.BoundedSemaphore(MAX_CONNECTIONS)  # corrections submitted, not yet done
        # an answer's warnings travel in its JSON; the warnings module is not one thread's
        warnings.simplefilter("ignore", CorrectionWarning)
        try:
            self.httpd = _Server((host, int(port)), _handler(self))
        except OSError as exc:  # an unknown host, a port in use or not allowed
            self._pool.shutdown(wait=False)
            raise InputError(f"--host {host} --port {port}: cannot listen there "
                             f"({exc.strerror or exc})") from None

    @property
    def port(self) -> int:
        return int(self.httpd.server_address[1])

    @property
    def url(self) -> str:
        host = self.httpd.server_address[0]
        return f"http://{'[' + host + ']' if ':' in host else host}:{self.port}"

    def serve_forever(self) -> None:
        """Answer requests until interrupted (Ctrl-C) or `shutdown`."""
        try:
            self.httpd.serve_forever(poll_interval=0.2)
        finally:
            self.httpd.server_close()
            self._pool.shutdown(wait=False, cancel_futures=True)

    def shutdown(self) -> None:
        self.httpd.shutdown()

    # ------------------------------------------------------------------ the protocol
    def info(self) -> dict:
        return {"protocolVersion": PROTOCOL_VERSION, "models": list(MODELS)}

    def model_info(self, request: dict) -> dict:
        self._model(request)
        return {"support": {"Evaluate": True, "Gradient": False, "ApplyJacobian": False, "ApplyHessian": False}}

    def input_sizes(self, request: dict) -> dict:
        self._model(request)
        return {"inputSizes": [3]}

    def output_sizes(self, request: dict) -> dict:
        self._model(request)
        return {"outputSizes": [len(OUTPUT_NAMES)]}

    def evaluate(self, request: dict) -> dict:
        name = self._model(request)
        values = self._input(request, name)
        config = self._config(request, name)
        renamed = config.pop("renamed")
        key = (name, tuple(sorted((k, v) for k, v in config.items() if k not in ("measurement_std_mm",
                                                                                    "measured_area_std_mm2",
                                                                                    "offset_std_mm", "seed"))))
        with self._guard:
            lock = self._locks.setdefault(key, threading.Lock())
        if not self._pending.acquire(blocking=False):
            raise _RequestError("Busy", "too many corrections are waiting: try again shortly", 503)
        future = self._pool.submit(self._correct, lock, name, values, config)
        future.add_done_callback(lambda _: self._pending.release())
        try:
            answer = future.result(timeout=self.request_timeout_s)
        except FutureTimeout:
            raise _RequestError("Timeout", f"the correction took longer than {self.request_timeout_s:g} s (a new "
                                "offset or load needs wheel-rail solves); it goes on, and the same request read "
                                "again shortly gets its answer", 503) from None
        lo, hi = answer["area_ci90_mm2"]
        out = {"output": [[float(answer["area_mm2"]), float(answer["area_std_mm2"]), float(lo), float(hi)]],
               "config": config, "provenance": answer["provenance"]}
        for extra in ("warnings", "patch", "not_included", "max_pressure_no_film_mpa"):
            if extra in answer:
                out[extra] = answer[extra]
        if renamed:
            out["warnings"] = [*out.get("warnings", []), *renamed]
        return out

    def _correct(self, lock: threading.Lock, name: str, values: list[float], config: dict) -> dict:
        from filmcal._errors import InputError
        from filmcal.study.correct import (
            ELASTIC_LIMIT_MPA, BodyRoughness, SphereMeasurement, WheelRailMeasurement, correct_measurement,
        )

        try:
            if name == "correct-sphere":
                measurement = SphereMeasurement(*values, measurement_std_mm=config["measurement_std_mm"])
                roughness = None
            else:
                measurement = WheelRailMeasurement(values[0], values[1], values[2],
                                                   measured_area_std_mm2=config["measured_area_std_mm2"],
                                                   offset_std_mm=config["offset_std_mm"])
                roughness = BodyRoughness(config["wheel_roughness_ra_um"], config["rail_roughness_ra_um"])
            with lock:
                answer, _ = correct_measurement(
                    self.study, config["film"], measurement, imprint_model=config["imprint_model"],
                    kinematics=config["kinematics"], calibration_forces_kn=config["calibration_forces_kn"],
                    roughness=roughness, seed=config["seed"], cache=self._cache,
                    elastic_limit_mpa=config.get("elastic_limit_mpa") or ELASTIC_LIMIT_MPA)
        except (ValueError, InputError, KeyError) as exc:
            raise _RequestError("InvalidInput", str(exc).strip("'\"")) from None
        return answer

    # ------------------------------------------------------------------ request checks
    @staticmethod
    def _model(request: dict) -> str:
        name = request.get("name")
        if name not in MODELS:
            raise _RequestError("ModelNotFound", f"model {name!r} not found; the models are {', '.join(MODELS)}")
        return name

    @staticmethod
    def _input(request: dict, name: str) -> list[float]:
        vectors = request.get("input")
        if not isinstance(vectors, list) or len(vectors) != 1 or not isinstance(vectors[0], list):
            raise _RequestError("InvalidInput", "input must be one vector: [[" + ", ".join(MODELS[name]) + "]]")
        if len(vectors[0]) != len(MODELS[name]):
            raise _RequestError("InvalidInput", f"input vector 0 has length {len(vectors[0])}; expected "
                                f"{len(MODELS[name])} ({', '.join(MODELS[name])})")
        return [_number(n, v) for n, v in zip(MODELS[name], vectors[0])]

    @staticmethod
    def _config(request: dict, name: str) -> dict:
        from filmcal.contact.names import IMPRINT_MODELS, KINEMATICS, MIXTURE

        given = request.get("config", {})
        if not isinstance(given, dict):
            raise _RequestError("InvalidInput", "config must be a JSON object")
        renamed = [k for k in RENAMED_CONFIG_KEYS if k in given and RENAMED_CONFIG_KEYS[k] not in given]
        given = {RENAMED_CONFIG_KEYS[k] if k in renamed else k: v for k, v in given.items()}
        unknown = [k for k in given if CONFIG_KEYS.get(k) not in ("both", name)]
        if unknown:
            takes = [k for k, m in CONFIG_KEYS.items() if m in ("both", name)]
            raise _RequestError("InvalidInput", f"{name} takes config keys {', '.join(takes)}; got "
                                f"{', '.join(map(repr, unknown))}")
        film = given.get("film")
        if not isinstance(film, str) or not film:
            raise _RequestError("InvalidInput", 'config needs the film, e.g. {"film": "HS"}')
        config: dict[str, Any] = {"film": film, "imprint_model": given.get("imprint_model", MIXTURE),
                                  "kinematics": given.get("kinematics"),
                                  "calibration_forces_kn": given.get("calibration_forces_kn")}
        for k in ("imprint_model", "kinematics", "calibration_forces_kn"):
            if config[k] is not None and not isinstance(config[k], str):
                raise _RequestError("InvalidInput", f"config {k} must be a string, got {config[k]!r}")
        for k, known in (("imprint_model", (*IMPRINT_MODELS, MIXTURE)), ("kinematics", KINEMATICS)):
            if config[k] is not None and config[k] not in known:
                raise _RequestError("InvalidInput", f"config {k} must be one of {', '.join(known)}, "
                                    f"got {config[k]!r}")
        seed = given.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**32:
            raise _RequestError("InvalidInput", f"config seed must be an integer in [0, 2^32), got {seed!r}")
        config["seed"] = seed
        if "elastic_limit_mpa" in given:
            config["elastic_limit_mpa"] = _number("elastic_limit_mpa", given["elastic_limit_mpa"], 100.0, 1e4)
        if name == "correct-sphere":
            config["measurement_std_mm"] = _number("measurement_std_mm", given.get("measurement_std_mm", 0.0), 0.0,
                                                   1e3)
        else:
            config["measured_area_std_mm2"] = _number("measured_area_std_mm2", given.get("measured_area_std_mm2", 0.0),
                                                    0.0, 1e5)
            config["offset_std_mm"] = _number("offset_std_mm", given.get("offset_std_mm", 0.0), 0.0, 10.0)
            for k in ("wheel_roughness_ra_um", "rail_roughness_ra_um"):
                config[k] = _number(k, given.get(k, 0.0), 0.0, 30.0)
        config["renamed"] = [f"config {k} is renamed {RENAMED_CONFIG_KEYS[k]}; the old name goes in the next release"
                             for k in renamed]
        return config


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    request_queue_size = 128

    def process_request(self, request, client_address):
        server: CorrectionServer = self.RequestHandlerClass.owner
        if not server._slots.acquire(blocking=False):
            body = json.dumps({"error": {"type": "Busy", "message": "too many connections: try again shortly"}})
            try:
                request.sendall(f"HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
                                f"Connection: close\r\nContent-Length: {len(body)}\r\n\r\n{body}".encode())
            except OSError:
                pass
            self.shutdown_request(request)
            return
        super().process_request(request, client_address)

    def handle_error(self, request, client_address):
        import sys

        if isinstance(sys.exc_info()[1], (ConnectionError, TimeoutError)):
            return  # the client went away or fell silent: nothing to answer, nothing to say
        super().handle_error(request, client_address)

    def process_request_thread(self, request, client_address):
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.RequestHandlerClass.owner._slots.release()


def _handler(owner: CorrectionServer) -> type:
    class Handler(BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"
        server_version = "filmcal-umbridge"
        timeout = CLIENT_TIMEOUT_S

        def log_message(self, format, *args):  # noqa: A002 (the base class's name)
            pass  # one line per request would drown the terminal; errors travel in the answers

        def _send(self, status: int, body: dict, close: bool = False) -> None:
            data = json.dumps(body).encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            if close:
                self.send_header("Connection", "close")
                self.close_connection = True
            self.end_headers()
            self.wfile.write(data)

        def _error(self, exc: _RequestError, close: bool = False) -> None:
            self._send(exc.status, {"error": {"type": exc.kind, "message": str(exc)}}, close)

        def send_error(self, code, message=None, explain=None):  # http.server's errors, as JSON like ours
            """Unsupported methods (DELETE, PUT, ...), malformed request lines and oversized headers."""
            if getattr(self, "command", None) in (None, "", "GET", "POST"):  # None, "": a malformed request line
                kind = "InvalidInput"
            else:
                kind = "UnsupportedFeature"
                message = f"no {self.command} requests: GET /Info, POST /Evaluate and the other UM-Bridge routes"
            body = json.dumps({"error": {"type": kind, "message": message or self.responses.get(code, ("",))[0]}})
            self.send_response(code, message)
            self.send_header("Content-Type", "application/json")
            self.send_header("Connection", "close")
            self.close_connection = True
            data = body.encode()
            send_body = getattr(self, "command", None) != "HEAD" and code >= 200 and code not in (204, 304)
            self.send_header("Content-Length", str(len(data) if send_body else 0))
            self.end_headers()
            if send_body:
                self.wfile.write(data)

        def _route(self) -> str:
            """The request's path without its query string or a trailing slash."""
            return self.path.split("?", 1)[0].rstrip("/")

        def do_GET(self):  # noqa: N802 (http.server's name)
            if self._route() == "/Info":
                self._send(200, owner.info())
            else:
                self._error(_RequestError("UnsupportedFeature", f"no GET {self.path}; GET /Info lists the models",
                                          404))

        def do_POST(self):  # noqa: N802
            routes = {"/Evaluate": owner.evaluate, "/InputSizes": owner.input_sizes,
                      "/OutputSizes": owner.output_sizes, "/ModelInfo": owner.model_info}
            try:
                request = self._body()
                route = routes.get(self._route())
                if route is None:
                    raise _RequestError("UnsupportedFeature", f"{self.path} is not served: only Evaluate (no "
                                        "Gradient, ApplyJacobian, ApplyHessian, shared memory)")
                self._send(200, route(request))
            except _RequestError as exc:
                self._error(exc, close=exc.status in (411, 413))
            except Exception as exc:  # a bug: said to the client, and the server goes on
                self._error(_RequestError("InternalError", f"{type(exc).__name__}: {exc}", 500))

        def _body(self) -> dict:
            if "chunked" in self.headers.get("Transfer-Encoding", "").lower():
                raise _RequestError("InvalidInput", "chunked bodies are not taken: send a Content-Length", 411)
            try:
                length = int(self.headers.get("Content-Length", ""))
            except ValueError:
                raise _RequestError("InvalidInput", "a request needs a Content-Length", 411) from None
            if not 0 <= length <= MAX_BODY_BYTES:
                raise _RequestError("InvalidInput", f"request body of {length} bytes; at most {MAX_BODY_BYTES}",
                                    413)
            raw = self.rfile.read(length)
            if len(raw) < length:
                raise _RequestError("InvalidInput", "the request body ended early", 400)
            try:
                request = json.loads(raw)
            except (ValueError, RecursionError) as exc:
                raise _RequestError("InvalidInput", f"the body is not JSON: {str(exc)[:120]}") from None
            if not isinstance(request, dict):
                raise _RequestError("InvalidInput", "the body must be a JSON object")
            return request

    Handler.owner = owner
    return Handler
