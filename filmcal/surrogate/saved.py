"""A saved GP surrogate read and predicted with numpy alone.

`filmcal.surrogate.io.load_surrogate` rebuilds a full `GPSurrogate` (a
scikit-learn estimator that can be refitted, cloned, differentiated). A
correction only predicts: `load_saved_surrogate` reads the same two files
(``<stem>.json``, ``<stem>.npz``) with the same checks, and predicts the
kernel ``C * Matern(nu=5/2, one length scale per input) + White`` directly:

    k(t, t') = C (1 + sqrt5 r + 5/3 r^2) exp(-sqrt5 r),  r = |(t - t') / l|,

conditioned on the stored training data with the stored hyperparameters (the
training covariance adds the white-noise variance on its diagonal). Its
predictions equal `GPSurrogate.predict` to rounding (tested to 1e-10), and
the recomputed log marginal likelihood is checked against the stored one, as
`load_surrogate` does. Nothing here imports scikit-learn or scipy.

Rounding: numpy's and scipy's LAPACK builds factorise the same kernel matrix
identically while it is reasonably conditioned; for a nearly singular one
(condition number ~1e13: long length scales and the white noise at its
lower bound) their Cholesky factors differ in the 8th digit. The full
study's 14 radius surrogates (28 Nov 2026) recompute their log marginal
likelihood within 1.4e-5 (relative) of the stored one, and predict within
2e-6 mm of `load_surrogate` over their domain: the check is
:data:`LML_REL_TOL` (1e-4), far below what a changed hyperparameter or data
value does. Beyond it `filmcal.surrogate.radius.load_for_prediction` hands
the files to `load_surrogate`, which decides with scipy as the fit did.
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from filmcal.surrogate.transforms import InputTransform, OutputTransform, as_input_matrix

__all__ = ["FORMAT", "FORMAT_VERSION", "SETTINGS", "SavedSurrogate", "load_saved_surrogate", "read_saved", "kernel_hyperparameters",
           "arrays_sha256"]

FORMAT = "filmcal-gp-surrogate"
FORMAT_VERSION = 1
#: The settings (`GPSurrogate.get_params`) a saved surrogate may name.
SETTINGS = ("constant_value_bounds", "input_bounds", "input_scaling", "inputs", "length_scale_bounds", "log_inputs",
            "n_jobs", "n_restarts", "noise_level", "noise_level_bounds", "output", "output_transform", "random_state")
_MATERN_NU = 2.5
_LEAF_KEYS = {"ConstantKernel": {"constant_value", "constant_value_bounds"},
              "Matern": {"length_scale", "length_scale_bounds", "nu"},
              "WhiteKernel": {"noise_level", "noise_level_bounds"}}


def base_path(path: str | Path) -> Path:
    """The stem of a saved pair, from the stem or either file."""
    path = Path(path)
    return path.with_suffix("") if path.suffix in (".json", ".npz") else path


def read_saved(path: str | Path) -> dict:
    """Read and check a saved surrogate's JSON description and arrays (no kernel object is built).

    Returns
    -------
    dict
        ``json_path``, ``meta`` (the parsed JSON), ``params``, ``input_transform``,
        ``output_transform``, ``n_train``, ``stored_lml``, ``restarts``, ``X``, ``y``.

    Raises
    ------
    FileNotFoundError
        If a file of the pair is missing.
    ValueError
        If the files are not a valid surrogate of this format version.
    """
    base = base_path(path)
    json_path = base.with_name(base.name + ".json")
    try:
        meta = json.loads(json_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{json_path}: not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ValueError(f"{json_path}: not a {FORMAT} file")
    if meta.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{json_path}: format version {meta.get('format_version')!r} is not supported "
                         f"(this is version {FORMAT_VERSION})")
    try:
        arrays_name = str(meta["arrays"])
        params = dict(meta["params"])
        input_transform = InputTransform.from_dict(meta["input_transform"])
        output_transform = OutputTransform.from_dict(meta["output_transform"])
        if not isinstance(meta["kernel"], Mapping):
            raise TypeError("kernel must be an object")
        n_train = int(meta["n_train"])
        stored_lml = float(meta["log_marginal_likelihood"])
        restarts = np.array([-np.inf if v is None else float(v) for v in meta["restart_log_marginal_likelihoods"]])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{json_path}: missing or invalid entry ({exc})") from None
    if Path(arrays_name).name != arrays_name:
        raise ValueError(f"{json_path}: 'arrays' must be a file name next to the JSON, got {arrays_name!r}")
    unknown = set(params) - set(SETTINGS)
    if unknown:
        raise ValueError(f"{json_path}: unknown setting(s) {sorted(unknown)}")
    if params.get("output", "y") != meta.get("output") \
            or list(input_transform.names) != meta.get("input_names"):
        raise ValueError(f"{json_path}: input/output names are inconsistent")
    X, y = _read_arrays(json_path.with_name(arrays_name), len(input_transform.names), n_train)
    if "arrays_sha256" in meta and meta["arrays_sha256"] != arrays_sha256(X, y):  # files written before have none
        raise ValueError(f"{json_path}: the training data in {arrays_name} are not those the surrogate was saved with "
                         "(their SHA-256 differs from the one recorded)")
    return {"json_path": json_path, "meta": meta, "params": params, "input_transform": input_transform,
            "output_transform": output_transform, "n_train": n_train, "stored_lml": stored_lml,
            "restarts": restarts, "X": X, "y": y}


def arrays_sha256(X: np.ndarray, y: np.ndarray) -> str:
    """SHA-256 of the training data as saved (float64, C order, X then y): the exact check that the data a
    surrogate is loaded with are those it was fitted on, whatever the numerics that refactorise its kernel."""
    import hashlib

    digest = hashlib.sha256(np.ascontiguousarray(X, dtype=np.float64).tobytes())
    digest.update(np.ascontiguousarray(y, dtype=np.float64).tobytes())
    return digest.hexdigest()


def _read_arrays(npz_path: Path, n_inputs: int, n_train: int) -> tuple[np.ndarray, np.ndarray]:
    with np.load(npz_path, allow_pickle=False) as arrays:
        if set(arrays.files) != {"X_train", "y_train"}:
            raise ValueError(f"{npz_path}: expected arrays X_train, y_train; found {sorted(arrays.files)}")
        X, y = arrays["X_train"], arrays["y_train"]
    if X.dtype != np.float64 or y.dtype != np.float64 or X.shape != (n_train, n_inputs) or y.shape != (n_train,):
        raise ValueError(f"{npz_path}: arrays do not match the JSON description "
                         f"(X_train {X.dtype} {X.shape}, y_train {y.dtype} {y.shape})")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise ValueError(f"{npz_path}: training data must be finite")
    return X, y


def _leaf(spec: object, name: str) -> dict:
    if not isinstance(spec, Mapping) or spec.get("type") not in _LEAF_KEYS:
        kind = spec.get("type") if isinstance(spec, Mapping) else spec
        raise ValueError(f"unknown kernel type {kind!r} where {name} is expected; the surrogate kernel must be "
                         f"ConstantKernel * Matern(nu={_MATERN_NU}) + WhiteKernel")
    if spec["type"] != name:
        raise ValueError(f"the surrogate kernel must be ConstantKernel * Matern(nu={_MATERN_NU}) + WhiteKernel, "
                         f"found {spec['type']} where {name} is expected")
    extra = set(spec) - _LEAF_KEYS[name] - {"type"}
    if extra:
        raise ValueError(f"unknown parameter(s) {sorted(extra)} for kernel {name}")
    return spec


def _positive(value: object, what: str, ndim: int) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if arr.ndim > ndim or not np.all(np.isfinite(arr)) or not np.all(arr > 0):
        raise ValueError(f"invalid value for {what}: {value!r}")
    return arr


def kernel_hyperparameters(spec: object) -> tuple[float, np.ndarray, float]:
    """(constant, length scales, white-noise variance) of a saved kernel ``C * Matern(5/2) + White``.

    Raises
    ------
    ValueError
        For any other kernel structure, an unknown type or parameter, or
        non-positive values.
    """
    pair = {"type", "k1", "k2"}
    if not isinstance(spec, Mapping) or spec.get("type") != "Sum" or set(spec) != pair:
        raise ValueError(f"unknown kernel type {spec.get('type') if isinstance(spec, Mapping) else spec!r}; "
                         f"the surrogate kernel must be ConstantKernel * Matern(nu={_MATERN_NU}) + WhiteKernel")
    product = spec["k1"]
    if not isinstance(product, Mapping) or product.get("type") != "Product" or set(product) != pair:
        raise ValueError(f"unknown kernel type {product.get('type') if isinstance(product, Mapping) else product!r}"
                         f"; the surrogate kernel must be ConstantKernel * Matern(nu={_MATERN_NU}) + WhiteKernel")
    constant = _leaf(product["k1"], "ConstantKernel")
    matern = _leaf(product["k2"], "Matern")
    white = _leaf(spec["k2"], "WhiteKernel")
    if float(matern.get("nu", 1.5)) != _MATERN_NU:
        raise ValueError(f"the surrogate kernel must be ConstantKernel * Matern(nu={_MATERN_NU}) + WhiteKernel, "
                         f"got Matern nu={matern.get('nu', 1.5)!r}")
    c = float(_positive(constant.get("constant_value", 1.0), "ConstantKernel.constant_value", 0))
    length = np.atleast_1d(_positive(matern.get("length_scale", 1.0), "Matern.length_scale", 1))
    noise = float(_positive(white.get("noise_level", 1.0), "WhiteKernel.noise_level", 0))
    return c, length, noise


def _matern52(A: np.ndarray, B: np.ndarray, constant: float, length: np.ndarray) -> np.ndarray:
    """``C * Matern(5/2)`` between the rows of A and B (GP coordinates), as scikit-learn computes it."""
    a, b = A / length, B / length
    r2 = np.zeros((len(a), len(b)))
    for k in range(a.shape[1]):  # summed input by input, as scipy's cdist/pdist do: the same rounding
        d = a[:, k, None] - b[None, :, k]
        r2 += d * d
    s = np.sqrt(r2) * np.sqrt(5.0)
    return constant * ((1.0 + s + s**2 / 3.0) * np.exp(-s))


def _forward(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve ``L V = B`` for lower-triangular L by forward substitution."""
    V = np.empty_like(B)
    for i in range(L.shape[0]):
        V[i] = (B[i] - L[i, :i] @ V[:i]) / L[i, i]
    return V


def _backward(U: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve ``U V = B`` for upper-triangular U by back substitution."""
    n = U.shape[0]
    V = np.empty_like(B)
    for i in range(n - 1, -1, -1):
        V[i] = (B[i] - U[i, i + 1:] @ V[i + 1:]) / U[i, i]
    return V


class SavedSurrogate:
    """A saved surrogate's predictions, computed with numpy alone.

    Attributes mirror `GPSurrogate`'s fitted ones: ``input_names_``,
    ``n_features_in_``, ``output``, ``X_train_``, ``y_train_``,
    ``input_transform_``, ``output_transform_``, ``X_gp_``, ``cholesky_``,
    ``dual_coef_``, ``log_marginal_likelihood_value_``, and the kernel's
    ``constant_value_``, ``length_scale_`` and ``noise_variance_``.
    """

    def __init__(self, X: np.ndarray, y: np.ndarray, input_transform: InputTransform,
                 output_transform: OutputTransform, constant: float, length_scale: np.ndarray, noise: float,
                 output: str = "y") -> None:
        names = list(input_transform.names)
        if length_scale.size not in (1, len(names)):
            raise ValueError(f"kernel has {length_scale.size} length scales for {len(names)} inputs")
        self.input_names_ = names
        self.n_features_in_ = len(names)
        self.output = output
        self.X_train_, self.y_train_ = X, y
        self.input_transform_, self.output_transform_ = input_transform, output_transform
        self.constant_value_ = float(constant)
        self.length_scale_ = np.broadcast_to(length_scale, (len(names),)).astype(float)
        self.noise_variance_ = float(noise)
        T, z = input_transform.transform(X), output_transform.transform(y)
        K = _matern52(T, T, self.constant_value_, self.length_scale_)
        K[np.diag_indices_from(K)] += self.noise_variance_
        try:
            L = np.linalg.cholesky(K)
        except np.linalg.LinAlgError:
            raise ValueError("the kernel matrix is not positive definite; raise noise_level_bounds[0]") from None
        self.X_gp_, self.cholesky_ = T, L
        self.dual_coef_ = _backward(L.T, _forward(L, z))
        self.log_marginal_likelihood_value_ = float(
            -0.5 * z @ self.dual_coef_ - np.log(np.diag(L)).sum() - 0.5 * z.size * np.log(2.0 * np.pi))

    def predict(self, X: object, return_std: bool = False, noise: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Predict the output in physical units, as `GPSurrogate.predict` does.

        Parameters
        ----------
        X : mapping, DataFrame, structured array or array_like of shape (m, d)
            Query points in physical units.
        return_std : bool
            Also return the predictive standard deviation (Jacobian of the
            output transform included).
        noise : bool
            Include the fitted white noise in the std.
        """
        T = self.input_transform_.transform(as_input_matrix(X, self.input_names_))
        Ks = _matern52(T, self.X_gp_, self.constant_value_, self.length_scale_)
        mean = Ks @ self.dual_coef_
        if not return_std:
            return self.output_transform_.inverse(mean)
        v = _forward(self.cholesky_, np.ascontiguousarray(Ks.T))
        var = np.maximum(self.constant_value_ - np.einsum("ij,ij->j", v, v), 0.0)
        if noise:
            var = var + self.noise_variance_
        return self.output_transform_.inverse(mean), self.output_transform_.derivative(mean) * np.sqrt(var)


#: Relative tolerance of the recomputed log marginal likelihood (module notes: rounding of nearly singular kernels).
LML_REL_TOL = 1e-4


def load_saved_surrogate(path: str | Path) -> SavedSurrogate:
    """Read a surrogate written by `filmcal.surrogate.io.save_surrogate`, for prediction only.

    The same checks as `load_surrogate` (format, version, settings, arrays,
    the kernel's structure, the log marginal likelihood that the stored data
    and hyperparameters must reproduce), without scikit-learn.

    Raises
    ------
    FileNotFoundError
        If a file of the pair is missing.
    ValueError
        If the files are not a valid surrogate of this format version.
    """
    saved = read_saved(path)
    json_path = saved["json_path"]
    try:
        constant, length, noise = kernel_hyperparameters(saved["meta"]["kernel"])
    except ValueError as exc:
        raise ValueError(f"{json_path}: {exc}") from None
    surrogate = SavedSurrogate(saved["X"], saved["y"], saved["input_transform"], saved["output_transform"],
                               constant, length, noise, output=str(saved["meta"].get("output", "y")))
    if not math.isclose(surrogate.log_marginal_likelihood_value_, saved["stored_lml"], rel_tol=LML_REL_TOL,
                        abs_tol=1e-8):
        raise ValueError(f"{json_path}: the stored data and hyperparameters do not reproduce the saved "
                         f"log marginal likelihood ({surrogate.log_marginal_likelihood_value_!r} != "
                         f"{saved['stored_lml']!r})")
    return surrogate
