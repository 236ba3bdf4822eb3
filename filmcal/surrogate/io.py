"""Save and load a fitted `GPSurrogate` as arrays + JSON (no pickle).

A surrogate saved under the base path ``p`` is two files:

``p.npz``
    The training data in physical units: ``X_train`` (n, d) and ``y_train`` (n,).
``p.json``
    Format name and version, the package versions, the estimator settings,
    the input/output transforms, the kernel as a tree of known kernel types
    with its fitted hyperparameters, and the log marginal likelihood.

Loading reads the arrays with ``allow_pickle=False``, rebuilds the kernel from
its JSON description (`filmcal.surrogate.kernels.kernel_from_dict`: known types
only, no code is evaluated; the files are read and checked by
`filmcal.surrogate.saved.read_saved`, which `load_saved_surrogate` shares to
predict with numpy alone) and conditions the GP on the stored data with the
stored hyperparameters, which reproduces the predictions of the saved object.
The recomputed log marginal likelihood is checked against the stored one.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import sklearn
from sklearn.utils.validation import check_is_fitted

from filmcal._io import atomic_open, atomic_write_text
from filmcal._versions import __version__
from filmcal.surrogate.gp import GPSurrogate
from filmcal.surrogate.kernels import kernel_from_dict, kernel_to_dict
from filmcal.surrogate.saved import FORMAT, FORMAT_VERSION, arrays_sha256, base_path, read_saved

__all__ = ["FORMAT", "FORMAT_VERSION", "save_surrogate", "load_surrogate"]

_base = base_path


#: Relative tolerance on the stored log marginal likelihood that a loaded surrogate must reproduce.
LML_REL_TOL = 1e-5


def _json_params(surrogate: GPSurrogate) -> dict:
    """Estimator settings as plain JSON values (a Generator seed is not saved)."""
    p = surrogate.get_params()
    seed = p["random_state"]
    return {
        "inputs": None if p["inputs"] is None else [str(n) for n in p["inputs"]],
        "output": str(p["output"]),
        "log_inputs": [str(n) for n in p["log_inputs"]],
        "input_scaling": str(p["input_scaling"]),
        "input_bounds": None if p["input_bounds"] is None else
        {str(k): [float(v) for v in lo_hi] for k, lo_hi in p["input_bounds"].items()},
        "output_transform": str(p["output_transform"]),
        "length_scale_bounds": [float(v) for v in p["length_scale_bounds"]],
        "constant_value_bounds": [float(v) for v in p["constant_value_bounds"]],
        "noise_level": float(p["noise_level"]),
        "noise_level_bounds": [float(v) for v in p["noise_level_bounds"]],
        "n_restarts": int(p["n_restarts"]),
        "n_jobs": None if p["n_jobs"] is None else int(p["n_jobs"]),
        "random_state": int(seed) if isinstance(seed, (int, np.integer)) else None,
    }


def _tuples(params: dict) -> dict:
    """JSON lists back to the tuples the settings are given as."""
    out = dict(params)
    for key in ("inputs", "log_inputs", "length_scale_bounds", "constant_value_bounds", "noise_level_bounds"):
        if isinstance(out.get(key), list):
            out[key] = tuple(out[key])
    if isinstance(out.get("input_bounds"), dict):
        out["input_bounds"] = {k: tuple(v) if isinstance(v, list) else v for k, v in out["input_bounds"].items()}
    return out


def save_surrogate(surrogate: GPSurrogate, path: str | Path) -> tuple[Path, Path]:
    """Write a fitted surrogate to ``<path>.json`` and ``<path>.npz``.

    Parameters
    ----------
    surrogate : GPSurrogate
        A fitted surrogate.
    path : str or Path
        Base path; a ``.json`` or ``.npz`` suffix is replaced.

    Returns
    -------
    (json_path, npz_path) : tuple of Path
    """
    check_is_fitted(surrogate)
    base = _base(path)
    json_path, npz_path = base.with_name(base.name + ".json"), base.with_name(base.name + ".npz")
    restarts = getattr(surrogate, "restart_log_marginal_likelihoods_", np.array([]))
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "filmcal_version": __version__,
        "sklearn_version": sklearn.__version__,
        "numpy_version": np.__version__,
        "arrays": npz_path.name,
        "params": _json_params(surrogate),
        "input_names": list(surrogate.input_names_),
        "output": surrogate.output,
        "n_train": int(surrogate.y_train_.size),
        "input_transform": surrogate.input_transform_.to_dict(),
        "output_transform": surrogate.output_transform_.to_dict(),
        "kernel": kernel_to_dict(surrogate.kernel_),
        "log_marginal_likelihood": surrogate.log_marginal_likelihood_value_,
        "restart_log_marginal_likelihoods": [float(v) if math.isfinite(v) else None for v in restarts],
    }
    X, y = np.asarray(surrogate.X_train_, dtype=np.float64), np.asarray(surrogate.y_train_, dtype=np.float64)
    meta["arrays_sha256"] = arrays_sha256(X, y)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(npz_path, "wb") as fh:  # an open file: savez adds no ".npz" to the temporary name
        np.savez(fh, X_train=X, y_train=y)
    # the JSON last and whole: its presence means both files are complete
    atomic_write_text(json_path, json.dumps(meta, indent=2, allow_nan=False) + "\n")
    return json_path, npz_path


def load_surrogate(path: str | Path) -> GPSurrogate:
    """Load a surrogate written by `save_surrogate`.

    Parameters
    ----------
    path : str or Path
        Base path, or the ``.json`` / ``.npz`` file of the pair.

    Returns
    -------
    GPSurrogate
        A fitted surrogate whose predictions equal those of the saved one.

    Raises
    ------
    FileNotFoundError
        If a file of the pair is missing.
    ValueError
        If the files are not a valid surrogate of this format version.
    """
    saved = read_saved(path)
    json_path, params = saved["json_path"], saved["params"]
    try:
        kernel = kernel_from_dict(saved["meta"]["kernel"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{json_path}: missing or invalid entry ({exc})") from None
    surrogate = GPSurrogate(**_tuples(params))
    X, y, stored_lml = saved["X"], saved["y"], saved["stored_lml"]
    input_transform, output_transform, restarts = saved["input_transform"], saved["output_transform"], saved["restarts"]
    surrogate._set_state(X, y, input_transform, output_transform, kernel)
    surrogate.restart_log_marginal_likelihoods_ = restarts
    # The data are checked exactly (`arrays_sha256`); this checks that the stored kernel reproduces the fit. A
    # nearly singular kernel matrix (condition ~1e13) factorised by another BLAS build or thread count differs by
    # ~1e-7 in its log marginal likelihood, and by 1.6e-6 between numpy 2.5 and 2.4 (a study made with Python
    # 3.13's tested set, read with 3.11's); an edited hyperparameter by far more.
    if not math.isclose(surrogate.log_marginal_likelihood_value_, stored_lml, rel_tol=LML_REL_TOL, abs_tol=1e-8):
        raise ValueError(f"{json_path}: the stored data and hyperparameters do not reproduce the saved "
                         f"log marginal likelihood ({surrogate.log_marginal_likelihood_value_!r} != {stored_lml!r})")
    return surrogate
