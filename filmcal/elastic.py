"""Isotropic linear elastic constants shared by the stages (a utility, not a stage)."""
from __future__ import annotations

import numpy as np

__all__ = ["lame_parameters", "oedometric_ratio", "oedometric_modulus_mpa"]


def lame_parameters(modulus_mpa: float, poisson: float) -> tuple[float, float]:
    """Lame's lambda and mu (MPa) of an isotropic material."""
    lam = modulus_mpa * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
    mu = modulus_mpa / (2.0 * (1.0 + poisson))
    return lam, mu


def oedometric_ratio(poisson):
    """M / E = (1 - nu) / ((1 + nu)(1 - 2 nu)) of an isotropic solid."""
    nu = np.asarray(poisson, dtype=float)
    ratio = (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    return float(ratio) if ratio.ndim == 0 else ratio


def oedometric_modulus_mpa(modulus_mpa, poisson):
    """Constrained (oedometric) modulus M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) in MPa.

    The stress-strain slope of a layer compressed through its thickness with no
    lateral strain: a thin film held laterally is compressed at M, so in a
    linear model the film's (E, nu) enter a contact only through M.
    """
    e, nu = np.asarray(modulus_mpa, dtype=float), np.asarray(poisson, dtype=float)
    if not (np.all(np.isfinite(e)) and np.all(e > 0.0)):
        raise ValueError(f"modulus_mpa must be finite and > 0, got {modulus_mpa!r}")
    if not (np.all(np.isfinite(nu)) and np.all((nu > -1.0) & (nu < 0.5))):
        raise ValueError(f"poisson must lie in (-1, 0.5), got {poisson!r}")
    m = e * np.asarray(oedometric_ratio(nu))
    return float(m) if m.ndim == 0 else m
