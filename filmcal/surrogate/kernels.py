"""The surrogate's covariance function and its JSON description.

The kernel is ``ConstantKernel * Matern(nu=2.5, anisotropic) + WhiteKernel``
from scikit-learn, in the GP coordinates of `filmcal.surrogate.transforms`
(inputs scaled to the unit cube or z-scores, output standardised). A kernel is
saved as a JSON tree of known kernel types and rebuilt from it by name and
keyword arguments only, so that loading a surrogate never executes code.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from sklearn.gaussian_process.kernels import ConstantKernel, Kernel, Matern, Product, Sum, WhiteKernel

__all__ = ["MATERN_NU", "make_kernel", "kernel_parts", "kernel_to_dict", "kernel_from_dict"]

#: Smoothness of the Matern kernel: twice mean-square differentiable functions.
MATERN_NU = 2.5

# Kernel types that a saved surrogate may name, with their numeric hyperparameters.
_LEAVES: dict[str, tuple[type, tuple[str, ...]]] = {
    "ConstantKernel": (ConstantKernel, ("constant_value",)),
    "Matern": (Matern, ("length_scale",)),
    "WhiteKernel": (WhiteKernel, ("noise_level",)),
}
_PAIRS: dict[str, type] = {"Sum": Sum, "Product": Product}


def make_kernel(n_inputs: int, *, length_scale: float = 0.5,
                length_scale_bounds: Sequence[float] = (1e-2, 1e3),
                constant_value: float = 1.0,
                constant_value_bounds: Sequence[float] = (1e-3, 1e4),
                noise_level: float = 1e-4,
                noise_level_bounds: Sequence[float] = (1e-8, 1e-1)) -> Kernel:
    """Return ``C * Matern(nu=2.5, anisotropic) + White`` for `n_inputs` inputs.

    Parameters
    ----------
    n_inputs : int
        Number of inputs (one length scale each).
    length_scale, constant_value, noise_level : float
        Initial hyperparameters (GP coordinates: scaled inputs, standardised output).
    length_scale_bounds, constant_value_bounds, noise_level_bounds : (float, float)
        Optimisation bounds of the hyperparameters.
    """
    signal = ConstantKernel(constant_value, tuple(constant_value_bounds))
    matern = Matern(length_scale=np.full(n_inputs, float(length_scale)),
                    length_scale_bounds=tuple(length_scale_bounds), nu=MATERN_NU)
    return signal * matern + WhiteKernel(noise_level, tuple(noise_level_bounds))


def kernel_parts(kernel: Kernel) -> tuple[ConstantKernel, Matern, WhiteKernel]:
    """Split ``C * Matern(nu=2.5) + White`` into its three parts.

    Raises
    ------
    ValueError
        If `kernel` does not have that structure.
    """
    if (isinstance(kernel, Sum) and isinstance(kernel.k1, Product) and isinstance(kernel.k2, WhiteKernel)
            and isinstance(kernel.k1.k1, ConstantKernel) and isinstance(kernel.k1.k2, Matern)
            and kernel.k1.k2.nu == MATERN_NU):
        return kernel.k1.k1, kernel.k1.k2, kernel.k2
    raise ValueError(f"the surrogate kernel must be ConstantKernel * Matern(nu={MATERN_NU}) + WhiteKernel, got {kernel}")


def _bounds_to_json(bounds: object) -> object:
    if isinstance(bounds, str):
        return bounds
    return np.asarray(bounds, dtype=float).tolist()


def _bounds_from_json(name: str, value: object) -> object:
    if value == "fixed":
        return "fixed"
    arr = np.asarray(value, dtype=float)
    if arr.shape[-1:] != (2,) or arr.ndim > 2 or not np.all(arr > 0) or np.any(arr[..., 0] > arr[..., 1]):
        raise ValueError(f"invalid bounds for {name}: {value!r}")
    return tuple(arr.tolist()) if arr.ndim == 1 else arr


def kernel_to_dict(kernel: Kernel) -> dict:
    """JSON-able tree describing `kernel` (known kernel types only)."""
    name = type(kernel).__name__
    if name in _PAIRS:
        return {"type": name, "k1": kernel_to_dict(kernel.k1), "k2": kernel_to_dict(kernel.k2)}
    if name not in _LEAVES:
        raise ValueError(f"cannot describe kernel type {name}; known: {sorted(_LEAVES) + sorted(_PAIRS)}")
    params = kernel.get_params(deep=False)
    spec: dict = {"type": name}
    for key, value in params.items():
        if key.endswith("_bounds"):
            spec[key] = _bounds_to_json(value)
        else:
            arr = np.asarray(value, dtype=float)
            spec[key] = arr.tolist() if arr.ndim else float(arr)
    return spec


def kernel_from_dict(spec: Mapping, depth: int = 0) -> Kernel:
    """Rebuild a kernel from `kernel_to_dict` output.

    Only the types ConstantKernel, Matern, WhiteKernel, Sum and Product are
    accepted, with their documented keyword arguments; anything else raises a
    `ValueError`. No code is evaluated.
    """
    if depth > 8 or not isinstance(spec, Mapping):
        raise ValueError("invalid kernel description")
    name = spec.get("type")
    if name in _PAIRS:
        if set(spec) != {"type", "k1", "k2"}:
            raise ValueError(f"invalid {name} kernel description: keys {sorted(spec)}")
        return _PAIRS[name](kernel_from_dict(spec["k1"], depth + 1), kernel_from_dict(spec["k2"], depth + 1))
    if name not in _LEAVES:
        raise ValueError(f"unknown kernel type {name!r}; known: {sorted(_LEAVES) + sorted(_PAIRS)}")
    cls, values = _LEAVES[name]
    allowed = set(cls().get_params(deep=False))
    extra = set(spec) - allowed - {"type"}
    if extra:
        raise ValueError(f"unknown parameter(s) {sorted(extra)} for kernel {name}")
    kwargs: dict = {}
    for key in allowed & set(spec):
        value = spec[key]
        if key.endswith("_bounds"):
            kwargs[key] = _bounds_from_json(f"{name}.{key}", value)
        else:
            arr = np.asarray(value, dtype=float)
            if arr.ndim > 1 or not np.all(np.isfinite(arr)) or (key in values and not np.all(arr > 0)):
                raise ValueError(f"invalid value for {name}.{key}: {value!r}")
            kwargs[key] = arr if arr.ndim else float(arr)
    return cls(**kwargs)
