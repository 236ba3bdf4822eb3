"""Waviness and micro-roughness: a measured surface split at the contact grid.

A boundary-element law (`filmcal.contact.roughness`) describes asperities much smaller than the contact
grid: it acts in series at every cell. Wavelengths longer than a few grid cells are no such asperities: a
turned wheel's feed marks (0.1-1 mm apart at Ra 10-30 um) or a ground rail's grinding marks change the gap
from cell to cell, so the contact and the imprint become striped. A surface is therefore split at the cut-off
``WAVINESS_CUTOFF_CELLS`` grid cells (0.4 mm on the default 0.1 mm grid) by the Gaussian filter of ISO
16610-21 (transmission of the long-wave part ``exp(-pi (alpha lambda_c / lambda)^2)``, ``alpha =
sqrt(ln 2 / pi)``: 50 % at the cut-off), applied in the Fourier domain of the periodic map: the short-wave
part is the micro surface of the law, the long-wave part (`Waviness`) is added to the macro gap of the
solve.

Orientation of a map on the contact grid: its first axis runs across the lay (the lateral direction of a
wheel or rail, the contact plane's ``s``), its second along it (the rolling direction ``x``); a line profile
measured across the lay is a map that is constant along it (`filmcal.contact.surface_files.profile_surface`).
The map is repeated periodically over the contact plane from the plane's origin (``x = 0, s = 0``), shifted by
``offset_mm``, so that every solve of one configuration (with and without film, smooth start or rough) sees the
same stripes in the same places, whatever grid region it solves on. Where the crests fall on the patch is not
known from a measured surface: each draw of the roughness inputs lays the map at its own random phase
(`Waviness.shifted`, seeded by the draw), so the bands carry it. Two bodies' maps on different pixel grids add their gaps
(`Waviness.__add__`).
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Waviness", "WavinessSum", "split_surface", "WAVINESS_CUTOFF_CELLS", "gaussian_transmission"]

#: Cut-off of the split in contact-grid cells: longer wavelengths belong to the macro gap.
WAVINESS_CUTOFF_CELLS = 4.0

_ALPHA = math.sqrt(math.log(2.0) / math.pi)


def gaussian_transmission(wavelength_um, cutoff_um: float):
    """The share of a wave of ``wavelength_um`` that the ISO 16610-21 Gaussian filter of cut-off ``cutoff_um``
    keeps in the long-wave (waviness) part: ``exp(-pi (alpha cutoff / wavelength)^2)``; 0.5 at the cut-off."""
    lam = np.asarray(wavelength_um, dtype=float)
    with np.errstate(divide="ignore"):
        return np.exp(-math.pi * (_ALPHA * float(cutoff_um) / lam) ** 2)


@dataclass(frozen=True, eq=False)
class Waviness:
    """The long-wave part of the bodies' surfaces: heights (um) added to the macro gap, periodic.

    Attributes
    ----------
    heights_um : ndarray, shape (n_across, n_along)
        Heights towards the other body (the gap closes where they are positive); first axis across the lay
        (contact-plane ``s``), second along it (rolling ``x``).
    pixel_um : float
    description : str
    """

    heights_um: np.ndarray = field(repr=False)
    pixel_um: float
    description: str = ""
    offset_mm: tuple = (0.0, 0.0)

    @property
    def rms_um(self) -> float:
        return float(np.std(self.heights_um))

    @property
    def period_mm(self) -> tuple[float, float]:
        """The map's periods (mm) along x (rolling) and s (across the lay)."""
        n_s, n_x = self.heights_um.shape
        return 1e-3 * n_x * self.pixel_um, 1e-3 * n_s * self.pixel_um

    def shifted(self, random_state) -> "Waviness":
        """The same map laid at a random phase (uniform over its periods): where the crests fall on the patch
        is not known from a measured surface, so each draw of the roughness inputs lays it anew."""
        rng = np.random.default_rng(random_state)
        px, ps = self.period_mm
        return Waviness(self.heights_um, self.pixel_um, self.description,
                        (float(rng.uniform(0.0, px)), float(rng.uniform(0.0, ps))))

    def gap_mm(self, x_mm: np.ndarray, s_mm: np.ndarray) -> np.ndarray:
        """The heights (mm) at the cells of a tensor grid ``x_mm (nx,) x s_mm (ns,)`` of the contact plane, shape
        ``(nx, ns)``: the map repeated from the plane's origin, interpolated bilinearly."""
        x = np.asarray(x_mm, dtype=float) + self.offset_mm[0]
        s = np.asarray(s_mm, dtype=float) + self.offset_mm[1]
        h = self.heights_um
        n_s, n_x = h.shape
        fs, fx = 1e3 * s / self.pixel_um, 1e3 * x / self.pixel_um
        i0, j0 = np.floor(fs).astype(int), np.floor(fx).astype(int)
        ts, tx = (fs - i0)[None, :], (fx - j0)[:, None]
        i0, i1 = i0 % n_s, (i0 + 1) % n_s
        j0, j1 = j0 % n_x, (j0 + 1) % n_x
        value = ((1 - tx) * (1 - ts) * h[i0[None, :], j0[:, None]] + (1 - tx) * ts * h[i1[None, :], j0[:, None]]
                 + tx * (1 - ts) * h[i0[None, :], j1[:, None]] + tx * ts * h[i1[None, :], j1[:, None]])
        return 1e-3 * value

    def __add__(self, other):
        """Both bodies' waviness: their heights add in the gap (one map on one pixel grid, else a sum of maps)."""
        if other is None:
            return self
        if (isinstance(other, Waviness) and other.heights_um.shape == self.heights_um.shape
                and math.isclose(other.pixel_um, self.pixel_um)):
            return Waviness(self.heights_um + other.heights_um, self.pixel_um,
                            f"{self.description} + {other.description}")
        return WavinessSum((self, *getattr(other, "parts", (other,))))


@dataclass(frozen=True, eq=False)
class WavinessSum:
    """The waviness of two bodies measured on different pixel grids: their gaps add."""

    parts: tuple

    @property
    def description(self) -> str:
        return " + ".join(p.description for p in self.parts)

    @property
    def rms_um(self) -> float:
        """The RMS of the sum, the maps taken as independent."""
        return math.sqrt(sum(p.rms_um ** 2 for p in self.parts))

    def gap_mm(self, x_mm: np.ndarray, s_mm: np.ndarray) -> np.ndarray:
        return sum(p.gap_mm(x_mm, s_mm) for p in self.parts)

    def shifted(self, random_state) -> "WavinessSum":
        """Each body's map at its own random phase (`Waviness.shifted`)."""
        rng = np.random.default_rng(random_state)
        return WavinessSum(tuple(p.shifted(rng) for p in self.parts))

    def __add__(self, other):
        return self if other is None else WavinessSum((*self.parts, *getattr(other, "parts", (other,))))


def split_surface(surface, cutoff_um: float):
    """A surface's micro part (wavelengths shorter than ``cutoff_um``, for the boundary-element law) and its
    waviness (longer, for the macro gap), by the Gaussian filter of ISO 16610-21 (module notes).

    One surface split at one cut-off is split once per process while the surface lives, and its parts are
    shared: every draw of a measured map splits it alike, and each would otherwise hold two more copies of its
    heights (16 B per pixel and draw, 64 MiB per draw at the 2048 x 2048 cap).

    Returns
    -------
    (RoughSurface or None, Waviness or None)
        None for a part that does not exist: a map no longer than the cut-off along either axis has no
        waviness (it is returned as it is), one whose heights all pass into the waviness has no micro part.
    """
    size_um = np.array(np.shape(surface.heights_um)) * surface.pixel_um
    if np.all(size_um <= float(cutoff_um)):
        return surface, None
    splits = _SPLITS.setdefault(surface, {})
    key = float(cutoff_um)
    if key not in splits:
        splits[key] = _split(surface, key)
        for part in splits[key]:  # shared: read-only
            if part is not None:
                part.heights_um.flags.writeable = False
    return splits[key]


#: Each living surface's splits by cut-off (`split_surface`); a surface's entry goes with it.
_SPLITS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _split(surface, cutoff_um: float):
    h = np.asarray(surface.heights_um, dtype=float)
    q0 = np.fft.fftfreq(h.shape[0], d=surface.pixel_um)
    q1 = np.fft.fftfreq(h.shape[1], d=surface.pixel_um)
    q = np.hypot(q0[:, None], q1[None, :])  # cycles per um
    keep = np.exp(-math.pi * (_ALPHA * float(cutoff_um) * q) ** 2)
    long = np.real(np.fft.ifft2(np.fft.fft2(h) * keep))
    short = h - long
    scale = max(float(np.std(h)), 1e-300)
    micro = (type(surface)(short, surface.pixel_um, f"{surface.description}, wavelengths under {cutoff_um:g} um")
             if np.std(short) > 1e-6 * scale else None)
    wavy = (Waviness(long - long.mean(), surface.pixel_um,
                     f"{surface.description}, wavelengths over {cutoff_um:g} um")
            if np.std(long) > 1e-6 * scale else None)
    return micro, wavy
