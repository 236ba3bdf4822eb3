"""Rough steel against a Prescale film: a pressure-closure law from contact mechanics.

A rough steel surface (a wheel, a roughened flat) pressed on the film touches
it only at its asperities. On the scale of the contact grid (0.1 mm) the
interface behaves as a nonlinear spring in series with the film and the
bodies: the rough interface closes by ``c(p)`` under a nominal pressure
``p``. This module computes that law numerically from the surface itself and
returns it as an :class:`filmcal.contact.laws.TabularLaw`, usable at
the film-wheel interface of :mod:`filmcal.wheelrail` and at the film-flat
interface of :func:`filmcal.wheelrail.halfspace.sphere_on_flat_contact`.

Surface
-------
:class:`RoughSurface` holds a periodic height map (um on a square pixel grid).
:meth:`RoughSurface.synthetic` draws a Gaussian, self-affine surface with
random phases from a seeded ``numpy.random.Generator``: power spectral density
``C(q)`` flat below the roll-off wave number ``q_r``, ``~ q**(-2(1 + H))``
between ``q_r`` and the short-wavelength cut-off ``q_s``, zero above (Persson
et al. 2005, J. Phys.: Condens. Matter 17:R1; Jacobs, Junge & Pastewka 2017,
Surf. Topogr.: Metrol. Prop. 5:013001), scaled to the RMS height (from ``Ra``
as ``sqrt(pi/2) Ra``, exact for Gaussian heights); giving an RMS slope sets
``q_s``. :meth:`RoughSurface.from_csv` and :meth:`RoughSurface.from_image`
read measured height maps (a mean plane is removed; the map is used as one
period of a periodic surface).

Contact solve
-------------
The film is an elastic layer of thickness ``t`` on a rigid base (the steel
body under it is 30-300 times stiffer than the film), touched by the rough
steel half-space. For a surface pressure ``p(q) exp(i q.x)`` the layer's
surface moves by ``2 S(q t) p / (E*_f q)`` with ``E*_f = E_f / (1 - nu_f**2)``
and (plane-strain Airy solution per wave vector, traction-free shear at the
top, bonded at the base)::

    S(k) = ((3 - 4 nu)/2 sinh 2k - k) / ((3 - 4 nu) sinh(k)**2 + k**2 + 4 (1 - nu)**2)

``S -> 1`` for wavelengths short against the film (a half-space of film) and
``S -> k (1 - 2 nu) / (2 (1 - nu)**2)`` for long ones, the oedometric
compression ``t/M`` of the film. The rough steel adds ``2 p / (E*_s q)``. The
uniform mode ``q = 0`` (the film's own compression under the nominal
pressure) is left out: it is the film law's part of the closure.

Asperity pressures are capped by the film's indentation hardness ``H``
(elastic-perfectly-plastic surface, Almqvist et al. 2007, Wear 262:1020):
``0 <= p <= H``, the gap is zero where ``0 < p``. Default ``H = 300 MPa``:
Tabor's ``H ~ 3 Y`` with the yield stress of biaxially oriented PET film,
``Y ~ 100 MPa`` (typical BOPET data-sheet values 90-110 MPa), consistent with
nanoindentation hardness of PET films of 0.2-0.4 GPa. The effective film
moduli of the calibration describe the film with its capsule coating; the
hardness of the PET carrier is an upper bound for the coating's.

The problem (minimum complementary energy with ``mean(p) = p_nominal`` and the
bounds) is solved by the conjugate-gradient method of Polonsky & Keer (1999,
Wear 231:206) on the periodic grid with FFT convolutions, with the bound
``p <= H`` handled like the bound ``p >= 0`` (cells at a bound leave the
active set, and return when their gap says so). Load steps from a small
nominal pressure upwards, each started from the previous solution, give the
mean approach (closure) ``c(p)`` measured from the first touch. The law ends
where the real contact covers ``saturation_fraction`` of the area (default
0.9, or at ``0.9 H``): above, the interface is taken as hard (its closure
stays constant), since an elastic-perfectly-plastic *surface* model would let
a confined film sink without limit as the nominal pressure approaches ``H``.

The closure is measured from the first touch of the highest summit of the
sampled surface, an extreme value that differs between realisations (by about
1.5 um at 10 MPa between two 200 um samples of the same spectrum); the
pressure-closure shape above a few MPa, and the imprint growth it causes,
vary much less: at the representative conditioned inputs (sphere-on-flat
R 450 mm, 50 kN, Ra 1.5 um on the flat, each film at its calibrated median)
seeds 0-5 give MS +5.3..+5.7 %, HS +13.6..+14.3 %, HHS -0.5..-0.6 % (28 Nov
2026). The realisation is one of the law's uncertain inputs (each draw of
`filmcal.contact.rough_imprint.ROUGHNESS_PRIOR` has its own seed), so this
spread is inside every rough band. The law is
converged in the grid: the same surface on 512 instead of 256 pixels changes
the closure by < 0.1 % and the contact fractions by < 1 %.

What the film records
---------------------
The same solves give the distribution of local pressures at each nominal
pressure: :meth:`RoughContactLaw.fraction_above` is the fraction of the
nominal area where the local pressure exceeds a level (the film's activation
pressure): a rough surface colours spots of a film where the nominal pressure
is below its activation pressure, and leaves spots uncoloured above it.

Cross-checks
------------
:func:`bearing_area_closure_mm` (fully plastic limit: the Abbott-Firestone
truncation, ``A/A0 = p/H``) and :func:`persson_contact_fraction` (Persson's
elastic theory, ``erf(p / (E* h'_rms / sqrt 2))``) are analytic models the
numerical law is tested against where each holds.
"""
from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.fft as sfft
from threadpoolctl import threadpool_limits
from scipy.special import erf

from filmcal._validation import MIN_RA_UM, check_poisson, check_positive, check_range
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON
from filmcal.contact.laws import TabularLaw

__all__ = [
    "RoughSurface",
    "Roughness",
    "RoughContactLaw",
    "PET_HARDNESS_MPA",
    "STEEL_HARDNESS_MPA",
    "rough_contact_law",
    "steel_contact_law",
    "layer_compliance_factor",
    "bearing_area_closure_mm",
    "persson_contact_fraction",
    "solve_periodic_contact",
    "PeriodicContact",
    "WHEEL_SURFACE_DEFAULTS",
    "rough_law_cost",
    "LAW_BYTES_PER_PIXEL",
    "MIN_RA_UM",
]

#: Indentation hardness of the PET carrier (MPa): Tabor's 3 Y with Y ~ 100 MPa (BOPET).
PET_HARDNESS_MPA = 300.0
#: Indentation hardness of wheel and rail steel (MPa): about 280 HV (R260 rail 260-300 HB, ER7 wheels
#: 235-285 HB; HV ~ HB in this range), 9.81 MPa per HV unit.
STEEL_HARDNESS_MPA = 2750.0

#: The synthetic surface used for a wheel or flat given only by its Ra, with sources.
WHEEL_SURFACE_DEFAULTS: dict[str, object] = {
    "hurst": 0.8,
    "rolloff_wavelength_um": 50.0,
    "size_um": 200.0,
    "n": 256,
    "rms_slope": None,
    "cutoff_wavelength_um": None,
    "sources": (
        "Hurst exponent 0.8: typical of machined and worn steel (Persson et al. 2005, "
        "J. Phys.: Condens. Matter 17:R1; Jacobs, Junge & Pastewka 2017, Surf. Topogr. 5:013001); "
        "roll-off wavelength 50 um: about the mean profile-element spacing RSm of turned "
        "and ground steel at Ra 1-2 um; short cut-off 4 pixels = 3.1 um, near the ISO 3274 "
        "short-wavelength filter (2.5 um) used with Ra 0.1-2 um; "
        "RMS height sqrt(pi/2) Ra (Gaussian heights)."),
}


# ---------------------------------------------------------------------------
# surface
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RoughSurface:
    """A periodic height map.

    Parameters
    ----------
    heights_um : ndarray, shape (n, m)
        Heights (um) on a square pixel grid, positive towards the film; the
        mean is removed.
    pixel_um : float
        Pixel size (um), > 0.
    description : str
        Where the surface comes from (recorded with the law).
    """

    heights_um: np.ndarray = field(repr=False)
    pixel_um: float
    description: str = ""

    def __post_init__(self) -> None:
        h = np.asarray(self.heights_um, dtype=float)
        if h.ndim != 2 or min(h.shape) < 8:
            raise ValueError(f"heights_um must be a 2-D map of at least 8 x 8 pixels, got shape {h.shape}")
        if not np.all(np.isfinite(h)):
            raise ValueError("heights_um must be finite everywhere (found NaN or inf)")
        check_positive("pixel_um", self.pixel_um)
        h = h - h.mean()
        if not np.any(h != 0.0):
            raise ValueError("heights_um is flat: a rough surface needs height variations")
        h.setflags(write=False)
        object.__setattr__(self, "heights_um", h)
        object.__setattr__(self, "pixel_um", float(self.pixel_um))

    # -- constructors --------------------------------------------------------
    @classmethod
    def synthetic(cls, *, ra_um: float | None = None, rms_um: float | None = None,
                  hurst: float = 0.8, rolloff_wavelength_um: float = 50.0,
                  cutoff_wavelength_um: float | None = None, rms_slope: float | None = None,
                  size_um: float = 200.0, n: int = 256,
                  seed: int | np.random.Generator = 0) -> "RoughSurface":
        """A Gaussian self-affine surface with random phases.

        Parameters
        ----------
        ra_um, rms_um : float
            Arithmetic mean roughness Ra (um) or RMS height (um); give one.
            Ra is converted as ``rms = sqrt(pi/2) Ra``.
        hurst : float
            Hurst exponent H, 0 < H < 1 (PSD ``~ q**(-2(1+H))`` above the roll-off).
        rolloff_wavelength_um : float
            Roll-off wavelength (um): the PSD is flat at longer wavelengths.
            Must not exceed ``size_um``.
        cutoff_wavelength_um : float, optional
            Shortest wavelength (um), at least 2 pixels; default 4 pixels.
        rms_slope : float, optional
            RMS slope of the surface; when given, the short cut-off is chosen
            to give it (do not give ``cutoff_wavelength_um`` then).
        size_um : float
            Side of the periodic square (um).
        n : int
            Pixels per side (even, 16-2048).
        seed : int or numpy.random.Generator
            Random phases and amplitudes (same seed, same surface).
        """
        if (ra_um is None) == (rms_um is None):
            raise ValueError("give exactly one of ra_um and rms_um")
        if ra_um is not None:
            rms = math.sqrt(0.5 * math.pi) * check_range("ra_um", ra_um, MIN_RA_UM, 100.0, low_open=False)
        else:
            rms = check_range("rms_um", rms_um, math.sqrt(0.5 * math.pi) * MIN_RA_UM, 125.0, low_open=False)
        hurst = check_range("hurst", hurst, 0.0, 1.0)
        size = check_positive("size_um", size_um)
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 16 <= n <= 2048 or n % 2:
            raise ValueError(f"n must be an even integer in [16, 2048], got {n!r}")
        pixel = size / n
        lam_r = check_range("rolloff_wavelength_um", rolloff_wavelength_um, 0.0, size,
                            high_open=False)
        if rms_slope is not None and cutoff_wavelength_um is not None:
            raise ValueError("give rms_slope or cutoff_wavelength_um, not both")
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        fx = sfft.fftfreq(n, d=pixel)
        fy = sfft.rfftfreq(n, d=pixel)
        q = 2.0 * math.pi * np.hypot(fx[:, None], fy[None, :])
        q_r = 2.0 * math.pi / lam_r
        shape = (np.maximum(q, q_r) / q_r) ** (-2.0 * (1.0 + hurst))
        shape[0, 0] = 0.0
        spectrum = (rng.standard_normal(q.shape) + 1j * rng.standard_normal(q.shape))

        def make(q_s: float) -> np.ndarray:
            amp = np.sqrt(np.where(q <= q_s, shape, 0.0))
            h = sfft.irfft2(amp * spectrum, s=(n, n))
            return h * (rms / h.std())

        q_max = 2.0 * math.pi / (2.0 * pixel)
        if rms_slope is not None:
            target = check_range("rms_slope", rms_slope, 0.0, 10.0)
            lo, hi = 1.01 * q_r, q_max
            if _rms_slope(make(lo), pixel) > target or _rms_slope(make(hi), pixel) < target:
                raise ValueError(
                    f"rms_slope {target:g} cannot be reached with this RMS height, roll-off "
                    f"({lam_r:g} um) and pixel size ({pixel:g} um): achievable "
                    f"{_rms_slope(make(lo), pixel):.3g}-{_rms_slope(make(hi), pixel):.3g}")
            for _ in range(40):
                mid = math.sqrt(lo * hi)
                lo, hi = (mid, hi) if _rms_slope(make(mid), pixel) < target else (lo, mid)
            q_s = math.sqrt(lo * hi)
        else:
            lam_s = 4.0 * pixel if cutoff_wavelength_um is None else check_range(
                "cutoff_wavelength_um", cutoff_wavelength_um, 2.0 * pixel, lam_r, low_open=False)
            q_s = 2.0 * math.pi / lam_s
        heights = make(q_s)
        text = (f"synthetic self-affine: rms {rms:.3g} um, H {hurst:g}, roll-off {lam_r:g} um, "
                f"cut-off {2 * math.pi / q_s:.3g} um, {size:g} um square, {n} px")
        return cls(heights, pixel, text)

    @classmethod
    def from_csv(cls, path: str | Path, pixel_um: float, height_scale: float = 1.0) -> "RoughSurface":
        """A measured height map from a CSV (or whitespace-separated) file of heights.

        Parameters
        ----------
        path : path
            One row per line of pixels; a non-numeric header line is skipped.
        pixel_um : float
            Pixel size (um).
        height_scale : float
            Multiplies the numbers to give um (1 for heights in um, 1000 for mm).
        """
        path = Path(path)
        check_positive("pixel_um", pixel_um)
        check_positive("height_scale", height_scale)
        try:
            text = path.read_text()
        except FileNotFoundError:
            raise ValueError(f"height map {path}: not found") from None
        except IsADirectoryError:
            raise ValueError(f"height map {path}: a folder, not a file of heights") from None
        except UnicodeDecodeError:
            raise ValueError(f"height map {path}: a binary file, not a text file of heights (greyscale images are "
                             f"read from PNG or TIFF files, measured surfaces from x3p files)") from None
        rows = []
        for k, line in enumerate(text.splitlines()):
            items = [s for s in line.replace(",", " ").replace(";", " ").split() if s]
            if not items:
                continue
            try:
                rows.append([float(s) for s in items])
            except ValueError:
                if rows or k > 0:
                    raise ValueError(f"height map {path}: line {k + 1} is not numeric") from None
        if not rows or len({len(r) for r in rows}) != 1:
            raise ValueError(f"height map {path}: needs rows of equal length")
        return cls(np.array(rows) * height_scale, pixel_um, f"height map {path.name}")

    @classmethod
    def from_image(cls, path: str | Path, pixel_um: float, height_range_um: float) -> "RoughSurface":
        """A measured height map from a greyscale image (PNG, TIFF).

        Parameters
        ----------
        path : path
        pixel_um : float
            Pixel size (um).
        height_range_um : float
            Height difference (um) between the darkest (0) and brightest
            (full-scale) grey level; 8- and 16-bit images are read.
        """
        from PIL import Image, UnidentifiedImageError

        path = Path(path)
        check_positive("pixel_um", pixel_um)
        check_positive("height_range_um", height_range_um)
        try:
            with Image.open(path) as img:
                mode = img.mode
                data = np.asarray(img.convert("I") if mode not in ("L", "I;16", "I", "F")
                                  else img, dtype=float)
        except FileNotFoundError:
            raise ValueError(f"height image {path}: not found") from None
        except (UnidentifiedImageError, OSError) as exc:
            raise ValueError(f"height image {path}: not a readable image ({exc})") from None
        full = 65535.0 if mode.startswith("I;16") or data.max() > 255 else 255.0
        if data.ndim != 2:
            raise ValueError(f"height image {path}: must be greyscale")
        return cls(data / full * height_range_um, pixel_um, f"height image {path.name}")

    # -- statistics ----------------------------------------------------------
    @property
    def rms_um(self) -> float:
        """RMS height (um)."""
        return float(np.sqrt(np.mean(self.heights_um ** 2)))

    @property
    def ra_um(self) -> float:
        """Arithmetic mean roughness Ra (um), over the whole map."""
        return float(np.mean(np.abs(self.heights_um)))

    @property
    def rms_slope(self) -> float:
        """RMS slope (spectral derivative)."""
        return _rms_slope(self.heights_um, self.pixel_um)

    @property
    def size_um(self) -> tuple[float, float]:
        """Side lengths (um)."""
        return (self.heights_um.shape[0] * self.pixel_um, self.heights_um.shape[1] * self.pixel_um)

    def fingerprint(self) -> str:
        """A hash of the heights and pixel size (the cache key), computed once: the heights are read-only."""
        cached = self.__dict__.get("_fingerprint")
        if cached is None:
            digest = hashlib.sha256(np.ascontiguousarray(self.heights_um).tobytes())
            digest.update(repr((self.heights_um.shape, self.pixel_um)).encode())
            cached = digest.hexdigest()[:16]
            object.__setattr__(self, "_fingerprint", cached)
        return cached


def _rms_slope(heights_um: np.ndarray, pixel_um: float) -> float:
    n, m = heights_um.shape
    qx = 2.0 * math.pi * sfft.fftfreq(n, d=pixel_um)
    qy = 2.0 * math.pi * sfft.rfftfreq(m, d=pixel_um)
    spec = sfft.rfft2(heights_um)
    power = np.abs(spec) ** 2 * (qx[:, None] ** 2 + qy[None, :] ** 2)
    weight = np.full(qy.shape, 2.0)
    weight[0] = 1.0
    if m % 2 == 0:
        weight[-1] = 1.0
    return float(np.sqrt((power * weight[None, :]).sum()) / (n * m))


# ---------------------------------------------------------------------------
# the periodic contact problem
# ---------------------------------------------------------------------------
def layer_compliance_factor(qt: np.ndarray, poisson: float) -> np.ndarray:
    """``S(q t)``: surface compliance of a layer bonded to a rigid base, relative
    to a half-space of the same material (see the module notes).

    ``S -> 1`` for ``q t -> inf``; ``S ~ q t (1 - 2 nu) / (2 (1 - nu)**2)`` for
    ``q t -> 0`` (oedometric compression).
    """
    nu = check_poisson("poisson", poisson)
    k = np.asarray(qt, dtype=float)
    a = 3.0 - 4.0 * nu
    out = np.ones_like(k)
    small = k < 20.0
    ks = k[small]
    sh = np.sinh(ks)
    out[small] = (0.5 * a * np.sinh(2.0 * ks) - ks) / (a * sh * sh + ks * ks + 4.0 * (1.0 - nu) ** 2)
    return out


@dataclass
class PeriodicContact:
    """One solved load step of the periodic rough contact.

    Attributes
    ----------
    nominal_pressure_mpa : float
    closure_mm : float
        Approach of the rough surface's mean plane beyond the first touch.
    contact_fraction : float
        Fraction of the area in contact (``p > 0``).
    plastic_fraction : float
        Fraction at the hardness.
    pressure_mpa : ndarray
        Local pressures (float32 map).
    iterations : int
    converged : bool
    """

    nominal_pressure_mpa: float
    closure_mm: float
    contact_fraction: float
    plastic_fraction: float
    pressure_mpa: np.ndarray = field(repr=False)
    iterations: int
    converged: bool


class _PeriodicKernel:
    def __init__(self, shape: tuple[int, int], pixel_um: float, film_modulus_mpa: float,
                 film_poisson: float, film_thickness_um: float, steel_modulus_mpa: float,
                 steel_poisson: float) -> None:
        n, m = shape
        qx = 2.0 * math.pi * sfft.fftfreq(n, d=pixel_um)
        qy = 2.0 * math.pi * sfft.rfftfreq(m, d=pixel_um)
        q = np.hypot(qx[:, None], qy[None, :])
        q[0, 0] = 1.0
        e_film = film_modulus_mpa / (1.0 - film_poisson ** 2)
        e_steel = steel_modulus_mpa / (1.0 - steel_poisson ** 2)
        s = layer_compliance_factor(q * film_thickness_um, film_poisson)
        comp = 2.0 * s / (e_film * q) + 2.0 / (e_steel * q)  # um per MPa
        comp[0, 0] = 0.0
        self.spectrum = comp
        self.shape = shape

    def __call__(self, p: np.ndarray) -> np.ndarray:
        return sfft.irfft2(sfft.rfft2(p) * self.spectrum, s=self.shape)


def _balance(p: np.ndarray, total: float, hardness: float, gap: np.ndarray | None = None) -> None:
    """Adjust the cells below the cap (in place) until ``sum(p) = total``.

    Loaded cells below the cap are scaled; when they cannot take the load
    (all loaded cells at the cap), the unloaded cells with the smallest gap
    (the next to touch) are loaded.
    """
    for _ in range(200):
        deficit = total - p.sum()
        if abs(deficit) <= 1e-12 * total:
            return
        room = (p > 0.0) & (p < hardness)
        base = p[room].sum()
        if deficit < 0.0 and base <= 0.0:  # only capped cells: lower them
            capped = p > 0.0
            p[capped] += deficit / capped.sum()
        elif deficit < 0.0 or base > 1e-9 * total:
            p[room] *= 1.0 + deficit / base
        else:
            empty = np.flatnonzero(p.ravel() == 0.0)
            if empty.size == 0:
                return
            k = max(1, min(empty.size, int(0.1 * np.count_nonzero(p)) + 1))
            if gap is None or k == empty.size:
                nearest = empty[:k]
            else:  # the k smallest gaps (their order does not matter: they all get the same pressure)
                nearest = empty[np.argpartition(gap.ravel()[empty], k - 1)[:k]]
            p.ravel()[nearest] = min(hardness, deficit / k)
        np.clip(p, 0.0, hardness, out=p)


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """Sum of the elementwise product of two arrays of the same shape."""
    return float(np.dot(a.ravel(), b.ravel()))


def _pk_step(kernel: _PeriodicKernel, heights_um: np.ndarray, mean_p: float, hardness: float,
                p: np.ndarray, tol: float, max_iter: int) -> tuple[np.ndarray, float, int, bool]:
    """Polonsky-Keer CG with ``mean(p) = mean_p`` and ``0 <= p <= hardness``.

    Returns the pressure, the approach of the rough mean plane measured from
    the highest summit (um), the iterations and convergence.
    """
    total = mean_p * p.size
    p = p.copy()
    t = np.zeros_like(p)
    g_old, restart, converged = 1.0, True, False
    it = 0
    # sums over the free cells as dense products with the 0/1 mask (t is zero off the free cells)
    for it in range(1, max_iter + 1):
        free = (p > 0.0) & (p < hardness)
        if not free.any():
            free = p > 0.0
        mask = free.astype(p.dtype)
        n_free = float(np.count_nonzero(free))
        g = kernel(p) - heights_um
        g -= _dot(g, mask) / n_free
        gf = g * mask
        gg = _dot(gf, gf)
        beta = 0.0 if restart else gg / g_old
        t *= beta
        t += gf
        t *= mask
        g_old = gg
        r = kernel(t)
        curv = _dot(r, t) - _dot(r, mask) / n_free * float(t.sum())
        if curv <= 0.0:
            converged = True
            break
        tau = _dot(gf, t) / curv
        p_prev = p.copy()
        p -= tau * t
        np.clip(p, 0.0, hardness, out=p)
        join = (p == 0.0) & (g < 0.0)
        leave = (p == hardness) & (g > 0.0) & ~free
        restart = bool(join.any() or leave.any())
        p[join] = -tau * g[join]
        p[leave] = hardness - tau * g[leave]
        np.clip(p, 0.0, hardness, out=p)
        _balance(p, total, hardness, g)
        change = float(np.abs(p - p_prev).sum() / total)
        if change < tol:
            converged = True
            break
    free = (p > 0.0) & (p < hardness)
    loaded = free if free.any() else p > 0.0
    raw = kernel(p) - heights_um
    # gap = raw + h_max - delta = 0 on the free cells
    approach = float(heights_um.max() + raw[loaded].mean())
    return p, approach, it, converged


def _kkt_violation(kernel: _PeriodicKernel, heights_um: np.ndarray, p: np.ndarray,
                   hardness: float) -> float:
    """Largest violation of the contact conditions, relative to the RMS height: zero gap
    where ``0 < p < H``, no penetration where ``p = 0``, no opening where ``p = H``."""
    free = (p > 0.0) & (p < hardness)
    if not free.any():
        return math.inf
    g = kernel(p) - heights_um
    g -= g[free].mean()
    scale = float(heights_um.std())
    worst = float(np.abs(g[free]).max())
    zero = p == 0.0
    if zero.any():
        worst = max(worst, float(-g[zero].min()))
    capped = p >= hardness
    if capped.any():
        worst = max(worst, float(g[capped].max()))
    return worst / scale


def _project(x: np.ndarray, mean_p: float, hardness: float, mu: float | None = None) -> tuple[np.ndarray, float]:
    """Euclidean projection onto ``{0 <= p <= H, mean(p) = mean_p}``: ``clip(x - mu, 0, H)``.

    ``mean(clip(x - mu, 0, H))`` falls piecewise linearly in ``mu``, with slope minus the fraction of cells
    strictly between the bounds: Newton steps from ``mu`` (an iteration's last shift; None: the middle of the
    bracket) are exact once on the root's piece, and a bisection of the bracket takes over from any step that
    would leave it.
    """
    lo, hi = float(x.min()) - hardness - 1.0, float(x.max()) + 1.0
    if math.isinf(hardness):
        lo = float(x.min()) - mean_p - 1.0
    if mu is None or not lo < mu < hi:
        mu = 0.5 * (lo + hi)
    y = np.empty(x.shape)
    for _ in range(200):
        np.subtract(x, mu, out=y)
        np.clip(y, 0.0, hardness, out=y)
        excess = float(y.mean()) - mean_p
        if abs(excess) <= 1e-13 * mean_p:
            break
        if excess > 0.0:
            lo = mu
        else:
            hi = mu
        free = np.count_nonzero((y > 0.0) & (y < hardness))
        newton = mu + excess * y.size / free if free else hi
        mu = newton if lo < newton < hi else 0.5 * (lo + hi)
        if hi - lo <= 1e-13 * (1.0 + abs(mu)):
            break
    if abs(excess) > 1e-13 * mean_p:  # stopped on the bracket's width: the pressures of its last shift
        np.clip(x - mu, 0.0, hardness, out=y)
    return y, mu


def _fista_step(kernel: _PeriodicKernel, heights_um: np.ndarray, mean_p: float, hardness: float,
                p: np.ndarray, tol: float, max_iter: int) -> tuple[np.ndarray, float, int, bool]:
    """Accelerated projected gradient (Beck & Teboulle 2009, with the gradient restart of
    O'Donoghue & Candes 2015) on ``p.K p / 2 - h.p`` over the projection set; robust when
    most contact spots sit at the hardness. Returns as :func:`_pk_step`."""
    step = 1.0 / float(kernel.spectrum.max())
    total = mean_p * p.size
    p, mu = _project(p, mean_p, hardness)
    y, t = p.copy(), 1.0
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        grad = kernel(y) - heights_um
        p_new, mu = _project(y - step * grad, mean_p, hardness, mu)
        change = float(np.abs(p_new - p).sum() / total)
        t_new = 0.5 * (1.0 + math.sqrt(1.0 + 4.0 * t * t))
        if float(np.sum((y - p_new) * (p_new - p))) > 0.0:  # restart
            t_new, y = 1.0, p_new.copy()
        else:
            y = p_new + ((t - 1.0) / t_new) * (p_new - p)
        p, t = p_new, t_new
        if change < tol:
            converged = True
            break
    # on the free cells K p - h = -mu / step: the approach of the mean plane
    approach = float(heights_um.max() - mu / step)
    return p, approach, it, converged


def _solve_step(kernel: _PeriodicKernel, heights_um: np.ndarray, mean_p: float, hardness: float,
                p: np.ndarray, tol: float, max_iter: int,
                conjugate: bool = True) -> tuple[np.ndarray, float, int, bool, bool]:
    """Polonsky-Keer CG (fast while few spots are plastic), then the projected-gradient
    method from where it stopped when it has not converged in 150 iterations.

    ``conjugate=False`` starts with the projected gradient. The last value returned says whether the
    next load should try the CG: not once it has stalled (run out of iterations), as it does when many
    spots sit at the hardness."""
    its, stalled = 0, not conjugate
    if conjugate:
        p, approach, its, ok = _pk_step(kernel, heights_um, mean_p, hardness, p, tol, min(max_iter, 150))
        if ok and _kkt_violation(kernel, heights_um, p, hardness) <= 1e-3:
            return p, approach, its, ok, True
        stalled = not ok
    p2, approach, its2, ok = _fista_step(kernel, heights_um, mean_p, hardness, p, tol, 10 * max_iter)
    return p2, approach, its + its2, ok, not stalled


def solve_periodic_contact(surface: RoughSurface, nominal_pressures_mpa: np.ndarray, *,
                           film_modulus_mpa: float, film_poisson: float,
                           film_thickness_mm: float, hardness_mpa: float = PET_HARDNESS_MPA,
                           steel_modulus_mpa: float = STEEL_MODULUS_MPA,
                           steel_poisson: float = STEEL_POISSON, tol: float = 1e-6,
                           max_iter: int = 500,
                           stop_fraction: float = 1.0) -> list[PeriodicContact]:
    """Solve the periodic rough contact at increasing nominal pressures.

    Parameters
    ----------
    surface : RoughSurface
    nominal_pressures_mpa : array_like
        Increasing nominal pressures (MPa), each below ``hardness_mpa``.
    film_modulus_mpa, film_poisson, film_thickness_mm : float
        The film layer (on a rigid base); ``film_thickness_mm = inf`` gives
        a half-space of film material.
    hardness_mpa : float
        Cap on the local pressure (``inf``: elastic).
    steel_modulus_mpa, steel_poisson : float
        The rough steel body (elastic half-space).
    tol, max_iter : float, int
        Relative pressure change per CG step; iterations per load step.
    stop_fraction : float
        Stop after the first step whose real contact fraction reaches this.

    Returns
    -------
    list of PeriodicContact
    """
    e_f = check_positive("film_modulus_mpa", film_modulus_mpa)
    nu_f = check_poisson("film_poisson", film_poisson)
    t_um = 1e3 * float(film_thickness_mm)
    if not t_um > 0.0:
        raise ValueError(f"film_thickness_mm must be > 0, got {film_thickness_mm!r}")
    hard = float(hardness_mpa)
    if not hard > 0.0:
        raise ValueError(f"hardness_mpa must be > 0, got {hardness_mpa!r}")
    loads = np.asarray(nominal_pressures_mpa, dtype=float)
    if loads.ndim != 1 or loads.size == 0 or np.any(~np.isfinite(loads)) or np.any(loads <= 0.0) \
            or np.any(np.diff(loads) <= 0.0) or loads[-1] >= hard:
        raise ValueError("nominal_pressures_mpa must be increasing, > 0 and below hardness_mpa")
    if not surface.ra_um >= MIN_RA_UM:
        raise ValueError(f"the surface {surface.description or 'given'} has Ra {surface.ra_um:.3g} um, below {MIN_RA_UM:g} um: it is "
                         "smooth at the contact's scale; leave it out (a smooth body)")
    h = surface.heights_um
    kernel = _PeriodicKernel(h.shape, surface.pixel_um, e_f, nu_f, t_um,
                             check_positive("steel_modulus_mpa", steel_modulus_mpa),
                             check_poisson("steel_poisson", steel_poisson))
    # start: the highest part of the surface carries the first load
    p = np.where(h >= np.quantile(h, 0.99), 1.0, 0.0)
    out = []
    # once the CG has stalled at a load (many spots at the hardness: each one that reaches it restarts the CG),
    # the higher loads, with more spots there, start with the projected gradient: the same pressures within
    # the tolerance, 1.5-6.5 times faster on a stiff film (within 1.3e-6 of the closure, bench/rough_law_speed.py)
    conjugate = True
    for load in loads:
        p = np.minimum(p * (load / p.mean()), hard)
        _balance(p, load * p.size, hard, kernel(p) - h)
        # one BLAS thread, as in the workers: the dot products are too small to share, and with a busy core a
        # second thread only waits (a 128 x 128 law: 0.28 s against 0.78 s with the other core loaded)
        with threadpool_limits(limits=1, user_api="blas"):
            p, approach_um, its, ok, conjugate = _solve_step(kernel, h, float(load), hard, p, tol, max_iter,
                                                             conjugate)
        out.append(PeriodicContact(
            nominal_pressure_mpa=float(load), closure_mm=1e-3 * approach_um,
            contact_fraction=float(np.mean(p > 0.0)),
            plastic_fraction=float(np.mean(p >= hard * (1.0 - 1e-12))),
            pressure_mpa=p.astype(np.float32), iterations=its, converged=ok))
        if out[-1].contact_fraction >= stop_fraction:
            break
    return out


# ---------------------------------------------------------------------------
# the law
# ---------------------------------------------------------------------------
class RoughContactLaw(TabularLaw):
    """Pressure-closure law of a rough steel surface on the film, from the BEM.

    A :class:`~filmcal.contact.laws.TabularLaw` (closure as a monotone
    function of the nominal pressure; hard above the last tabulated pressure)
    that also keeps the local pressure distributions.

    Attributes
    ----------
    surface : RoughSurface
    film_modulus_mpa, film_poisson, film_thickness_mm, hardness_mpa : float
    steps : list of PeriodicContact
    """

    #: the closure added per MPa above the table (practically hard)
    _HARD_SLOPE_MM_PER_MPA = 1e-9

    def __init__(self, surface: RoughSurface, steps: list[PeriodicContact], *,
                 film_modulus_mpa: float, film_poisson: float, film_thickness_mm: float,
                 hardness_mpa: float) -> None:
        pressures = np.array([0.0] + [s.nominal_pressure_mpa for s in steps])
        closures = np.array([0.0] + [s.closure_mm for s in steps])
        closures = np.maximum.accumulate(closures)
        # strictly increasing for the interpolant (numerically flat steps nudged)
        closures = closures + 1e-12 * np.arange(closures.size)
        top = pressures[-1]
        pressures = np.append(pressures, top + 1e4)
        closures = np.append(closures, closures[-1] + 1e4 * self._HARD_SLOPE_MM_PER_MPA)
        super().__init__(closures, pressures)
        self.surface = surface
        self.steps = steps
        self.film_modulus_mpa = film_modulus_mpa
        self.film_poisson = film_poisson
        self.film_thickness_mm = film_thickness_mm
        self.hardness_mpa = hardness_mpa
        self.saturation_pressure_mpa = float(top)
        self._sorted = self._sorted_pressures()
        self._stain_means: dict = {}  # expected_stain's means over the steps, by the caller's key

    def _sorted_pressures(self) -> list[np.ndarray]:
        """The local pressures of each step, sorted (the distributions `fraction_above` reads)."""
        return [np.sort(s.pressure_mpa.ravel()).astype(float) for s in self.steps]

    def __getstate__(self) -> dict:
        # sent to worker processes without the sorted copies (twice the maps' size, rebuilt in ms)
        return {k: v for k, v in self.__dict__.items() if k not in ("_sorted", "_stain_means")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._sorted = self._sorted_pressures()
        self._stain_means = {}

    def contact_fraction(self, nominal_pressure_mpa: np.ndarray) -> np.ndarray:
        """Real contact fraction at nominal pressures (linear in between steps)."""
        p = np.asarray(nominal_pressure_mpa, dtype=float)
        xs = np.array([0.0] + [s.nominal_pressure_mpa for s in self.steps])
        ys = np.array([0.0] + [s.contact_fraction for s in self.steps])
        return np.interp(p, xs, ys)

    def fraction_above(self, level_mpa: float, nominal_pressure_mpa: np.ndarray) -> np.ndarray:
        """Fraction of the nominal area whose local pressure exceeds ``level_mpa``.

        Interpolated linearly in the nominal pressure between the solved
        steps (zero at zero pressure); above the last step the local
        distribution of the last step is shifted by the extra nominal
        pressure (full contact carries it uniformly).
        """
        level = check_positive("level_mpa", level_mpa)
        p = np.asarray(nominal_pressure_mpa, dtype=float)
        xs = np.array([0.0] + [s.nominal_pressure_mpa for s in self.steps])
        fr = np.array([0.0] + [1.0 - np.searchsorted(a, level, side="right") / a.size
                               for a in self._sorted])
        out = np.interp(p, xs, fr)
        top = xs[-1]
        above = p > top
        if np.any(above):
            last = self._sorted[-1]
            extra = p[above] - top
            out[above] = 1.0 - np.searchsorted(last, level - extra, side="right") / last.size
        return out

    def expected_stain(self, stain_probability, nominal_pressure_mpa: np.ndarray, key=None) -> np.ndarray:
        """Mean of ``stain_probability(local pressure)`` over the nominal area.

        Parameters
        ----------
        stain_probability : callable
            Local pressure (MPa) array -> probability in [0, 1] that the film
            colours there (``ImprintModel.stain_probability`` bound to a film).
        nominal_pressure_mpa : array_like
            Nominal pressures (MPa).
        key : hashable, optional
            A name of ``stain_probability`` (one key, one function): the law
            keeps its means over the solved steps under it for later calls.

        Returns
        -------
        ndarray
            The coloured fraction of the nominal area; interpolated linearly
            between the solved steps, and above the last step from its local
            pressures (1024 quantiles of them) shifted by the extra nominal
            pressure.
        """
        p = np.asarray(nominal_pressure_mpa, dtype=float)
        xs = np.array([0.0] + [s.nominal_pressure_mpa for s in self.steps])
        ys = self._stain_means.get(key) if key is not None else None
        if ys is None:
            ys = np.array([0.0] + [float(np.mean(stain_probability(a))) for a in self._sorted])
            if key is not None:
                self._stain_means[key] = ys
        out = np.interp(p, xs, ys)
        above = p > xs[-1]
        if np.any(above):
            # the last step's local pressures at 1024 midpoint quantiles (against all of them, within 6e-5 for the
            # capsule models of MS, HS and HHS: closer than every 16th of the sorted 65536 was, 1.2e-4)
            last = self._sorted[-1]
            last = last[((np.arange(min(1024, last.size)) + 0.5) * (last.size / min(1024, last.size))).astype(int)]
            out[above] = [float(np.mean(stain_probability(last + (q - xs[-1])))) for q in p[above]]
        return out

    def table(self) -> list[dict[str, float]]:
        """The solved steps as rows (pressure, closure, contact and plastic fractions)."""
        return [{"nominal_pressure_mpa": s.nominal_pressure_mpa, "closure_um": 1e3 * s.closure_mm,
                 "contact_fraction": s.contact_fraction, "plastic_fraction": s.plastic_fraction}
                for s in self.steps]

    def describe(self) -> dict[str, object]:
        """The law's parameters and their sources (JSON-ready)."""
        return {
            "surface": self.surface.description,
            "rms_um": self.surface.rms_um, "ra_um": self.surface.ra_um,
            "rms_slope": self.surface.rms_slope, "pixel_um": self.surface.pixel_um,
            "film_modulus_mpa": self.film_modulus_mpa, "film_poisson": self.film_poisson,
            "film_thickness_mm": self.film_thickness_mm, "hardness_mpa": self.hardness_mpa,
            "saturation_pressure_mpa": self.saturation_pressure_mpa,
            "closure_at_saturation_um": 1e3 * self.steps[-1].closure_mm,
            "hardness_source": ("steel, about 280 HV (wheel and rail)" if self.film_thickness_mm == math.inf
                                else "the film's coating: a draw of filmcal.contact.rough_imprint.ROUGHNESS_PRIOR "
                                     "conditioned on the paper's roughened flat"),
        }

    def __repr__(self) -> str:
        return (f"RoughContactLaw(rms {self.surface.rms_um:.3g} um, slope "
                f"{self.surface.rms_slope:.3g}, E_film {self.film_modulus_mpa:g} MPa, "
                f"H {self.hardness_mpa:g} MPa, up to {self.saturation_pressure_mpa:.3g} MPa)")


_CACHE: "OrderedDict[tuple, RoughContactLaw]" = OrderedDict()
_CACHE_SIZE = 32

#: What a finished law keeps per pixel of its surface (bytes): each of its (at most 32) load steps' local
#: pressures as float32 and, sorted, as float64 (`RoughContactLaw.steps`, `fraction_above`).
LAW_BYTES_PER_PIXEL = 32 * (4 + 8)
#: The solver's work arrays per pixel while a law is built (bytes; measured, see `rough_law_cost`).
LAW_WORK_BYTES_PER_PIXEL = 60
#: Seconds per pixel and iteration of the boundary-element solve (FFT convolutions; one BLAS thread on an
#: idle core of the reference machine: 0.025-0.032 s per million pixels and iteration), and the iterations
#: a law takes over its 32 load steps (measured on self-affine maps of 128-1024 pixels a side: 2200-3600
#: against a film, 470-610 steel on steel). A lower bound on a busy machine: the solver's vector products
#: run on every BLAS thread, and with the cores shared they were up to 60 times slower (a 128 x 128 law
#: against a film 1.4 s with one BLAS thread, 92 s with the default threads beside other work).
LAW_SECONDS_PER_PIXEL_ITERATION = 3.0e-8
LAW_ITERATIONS = {"film": 3000, "steel": 600}


def rough_law_cost(pixels: int, film_laws: int = 1, steel_laws: int = 0, copies: int = 1,
                   base_bytes: float = 0.0):
    """Estimated peak memory and time of building rough-contact laws on a map of `pixels` pixels.

    Model: each finished law keeps `LAW_BYTES_PER_PIXEL` (384 B) per pixel, the one being built adds
    `LAW_WORK_BYTES_PER_PIXEL` (60 B); a process holding ``film_laws + steel_laws`` laws (at most the cache's 32)
    peaks at ``base + pixels (60 + 384 laws)``, and ``copies`` processes that each hold them (worker processes
    that receive the laws) multiply it. Time: ``pixels x iterations x 3e-8 s`` per law, 3000 iterations
    against a film, 600 steel on steel (one process, an idle core: a lower bound, see
    `LAW_SECONDS_PER_PIXEL_ITERATION`). Measured (peak RSS in a subprocess, ``python bench/memory.py --only
    maps``): ``filmcal wheelrail`` with a film on a 1024 x 1024 map 510 MiB (101 MiB without the map), one
    steel law on 2048 x 2048 pixels 1.6 GiB, four laws on 512 x 512 pixels 412 MiB above the base: 398-428 B
    per pixel and law; estimate/measured 0.92 for both ``wheelrail`` cases.

    Returns
    -------
    filmcal._memory.MemoryEstimate
        With ``seconds``: the laws' build time in one process.
    """
    from filmcal._memory import MemoryEstimate

    laws = max(1, min(_CACHE_SIZE, int(film_laws) + int(steel_laws)))
    per_process = pixels * (LAW_WORK_BYTES_PER_PIXEL + LAW_BYTES_PER_PIXEL * laws)
    seconds = pixels * LAW_SECONDS_PER_PIXEL_ITERATION * (
        LAW_ITERATIONS["film"] * film_laws + LAW_ITERATIONS["steel"] * steel_laws)
    what = (f"{laws} boundary-element law{'s' if laws > 1 else ''} on {pixels / 1e6:.3g} million pixels"
            + (f" in each of {copies} processes" if copies > 1 else ""))
    return MemoryEstimate(base_bytes + max(1, int(copies)) * per_process, what,
                          "base + copies x pixels x (60 + 384 laws) B; pixels x 3e-8 s x (3000 film + 600 steel "
                          "laws)", seconds)


def rough_contact_law(surface: RoughSurface, film_modulus_mpa: float, film_poisson: float,
                      film_thickness_mm: float, *, hardness_mpa: float = PET_HARDNESS_MPA,
                      saturation_fraction: float = 0.9, n_steps: int = 32,
                      first_pressure_mpa: float = 0.05) -> RoughContactLaw:
    """The pressure-closure law of ``surface`` on a film (cached per process).

    Parameters
    ----------
    surface : RoughSurface
    film_modulus_mpa, film_poisson, film_thickness_mm : float
        The film (its calibrated modulus; thickness from the film registry).
    hardness_mpa : float
        Cap on asperity pressures (default :data:`PET_HARDNESS_MPA`).
    saturation_fraction : float
        The law ends where the real contact covers this fraction (0.5-0.99)
        or at 0.9 ``hardness_mpa``; above, the interface is hard.
    n_steps : int
        Load steps (geometric) from ``first_pressure_mpa`` to ``0.9 H``.
    first_pressure_mpa : float
        First nominal pressure (MPa).

    Returns
    -------
    RoughContactLaw
    """
    e_f = check_positive("film_modulus_mpa", film_modulus_mpa)
    nu_f = check_poisson("film_poisson", film_poisson)
    t = math.inf if film_thickness_mm == math.inf else check_positive("film_thickness_mm", film_thickness_mm)
    hard = check_positive("hardness_mpa", hardness_mpa)
    sat = check_range("saturation_fraction", saturation_fraction, 0.5, 0.99, low_open=False,
                      high_open=False)
    steps_n = int(check_range("n_steps", n_steps, 4, 200, low_open=False, high_open=False))
    p_first = check_range("first_pressure_mpa", first_pressure_mpa, 0.0, 0.1 * hard)
    key = (surface.fingerprint(), e_f, nu_f, t, hard, sat, steps_n, p_first)
    law = _CACHE.get(key)
    if law is not None:
        _CACHE.move_to_end(key)
        return law
    loads = np.geomspace(p_first, 0.9 * hard, steps_n)
    kept = solve_periodic_contact(surface, loads, film_modulus_mpa=e_f, film_poisson=nu_f,
                                  film_thickness_mm=t, hardness_mpa=hard, stop_fraction=sat)
    law = RoughContactLaw(surface, kept, film_modulus_mpa=e_f, film_poisson=nu_f,
                          film_thickness_mm=t, hardness_mpa=hard)
    _CACHE[key] = law
    while len(_CACHE) > _CACHE_SIZE:
        _CACHE.popitem(last=False)
    return law


def steel_contact_law(surface: RoughSurface, *, hardness_mpa: float = STEEL_HARDNESS_MPA) -> RoughContactLaw:
    """The pressure-closure law of rough steel on steel without film (cached per process).

    The boundary-element mechanics of `rough_contact_law` with the film replaced by a steel half-space: two
    elastic steel bodies whose composite roughness is ``surface`` (two rough bodies add their heights: a sum
    surface of RMS ``sqrt(rms_1**2 + rms_2**2)``), asperity pressures capped by the steel's hardness. In series
    with the smooth bodies it gives the rough Hertz contact: on sphere-on-flat its peak pressure follows
    Greenwood & Tripp's as correlated by Bahrami et al. (J. Thermophys. Heat Transfer 18, 2004),
    ``P0 / P0_Hertz = 1 / (1 + 1.37 alpha tau**-0.075)``, alpha = sigma R / a0**2, tau = R / a0, within 1 %
    (``tests/test_roughness_no_film.py``).

    Parameters
    ----------
    surface : RoughSurface
        The composite surface of the two bodies.
    hardness_mpa : float
        Cap on asperity pressures (default :data:`STEEL_HARDNESS_MPA`).
    """
    return rough_contact_law(surface, STEEL_MODULUS_MPA, STEEL_POISSON, math.inf, hardness_mpa=hardness_mpa)


@dataclass(frozen=True, eq=False)
class Roughness:
    """The roughness of both bodies of a contact: the wheel and the rail (or the sphere and the flat).

    The one roughness value a correction, a curve or a solve takes (docs/film-law.md); synthetic bodies of an
    Ra come from a draw of the roughness inputs (`filmcal.contact.rough_imprint.RoughnessInputs.bodies`). With a film between
    the bodies each rough body is pressed into its own face of the film: their closure laws
    (`rough_contact_law`) act in series with the film. Without film the two surfaces touch each other: their
    heights add into one composite surface against steel (`steel_contact_law`).

    Attributes
    ----------
    wheel, rail : RoughSurface or None
        The bodies' surfaces (None: smooth); after `split`, their micro parts.
    film_hardness_mpa : float
        Cap on asperity pressures in the film (default: the PET carrier's, :data:`PET_HARDNESS_MPA`).
    waviness : filmcal.contact.waviness.Waviness or None
        Both bodies' long-wave heights for the macro gap (`split`).
    """

    wheel: RoughSurface | None = None
    rail: RoughSurface | None = None
    film_hardness_mpa: float = PET_HARDNESS_MPA
    waviness: Any = None

    def __post_init__(self) -> None:
        from filmcal._validation import HARDNESS_MPA_BOUNDS

        check_range("film_hardness_mpa", self.film_hardness_mpa, *HARDNESS_MPA_BOUNDS, low_open=False,
                    high_open=False)
        for name in ("wheel", "rail"):
            if getattr(self, name) is not None and not isinstance(getattr(self, name), RoughSurface):
                raise ValueError(f"{name} must be a RoughSurface or None, got {type(getattr(self, name)).__name__}")

    @property
    def smooth(self) -> bool:
        return self.wheel is None and self.rail is None and self.waviness is None

    def split(self, cutoff_um: float) -> "Roughness":
        """The bodies split at ``cutoff_um`` (`filmcal.contact.waviness.split_surface`): their micro parts for the
        laws, their waviness (added) for the macro gap of the solve (``waviness``)."""
        from filmcal.contact.waviness import split_surface

        parts = [(None, None) if s is None else split_surface(s, cutoff_um) for s in (self.wheel, self.rail)]
        wavy = [w for _, w in parts if w is not None]
        total = self.waviness
        for w in wavy:
            total = w if total is None else total + w
        return Roughness(parts[0][0], parts[1][0], self.film_hardness_mpa, total)

    def composite(self) -> RoughSurface | None:
        """The two surfaces' heights added (the gap between them), or the one rough surface."""
        if self.wheel is None or self.rail is None:
            return self.wheel if self.rail is None else self.rail
        a, b = self.wheel, self.rail
        if a.heights_um.shape != b.heights_um.shape or abs(a.pixel_um - b.pixel_um) > 1e-9 * a.pixel_um:
            raise ValueError(f"the wheel's and the rail's height maps differ in size or pixel ({a.heights_um.shape} "
                             f"at {a.pixel_um:g} um, {b.heights_um.shape} at {b.pixel_um:g} um): give them on "
                             "one grid")
        return RoughSurface(a.heights_um + b.heights_um, a.pixel_um,
                            f"wheel ({a.description}) + rail ({b.description})")

    def film_law(self, film_modulus_mpa: float, film_poisson: float, film_thickness_mm: float):
        """The rough bodies' closure against a film: each body's law in series (None when smooth)."""
        from filmcal.contact.laws import SeriesLaw

        laws = [rough_contact_law(surface, film_modulus_mpa, film_poisson, film_thickness_mm,
                                  hardness_mpa=self.film_hardness_mpa) for surface in (self.wheel, self.rail)
                if surface is not None]
        if not laws:
            return None
        return laws[0] if len(laws) == 1 else SeriesLaw(*laws)

    def steel_law(self):
        """The rough bodies' closure against each other without film (None when smooth).

        Their heights add into one composite surface when both are on one grid (synthetic draws, or maps of
        one instrument); two measured surfaces on different grids act as two laws in series, each against
        smooth steel (the closures add; an approximation of the composite surface's)."""
        from filmcal.contact.laws import SeriesLaw

        a, b = self.wheel, self.rail
        if a is not None and b is not None and (a.heights_um.shape != b.heights_um.shape
                                                or abs(a.pixel_um - b.pixel_um) > 1e-9 * a.pixel_um):
            return SeriesLaw(steel_contact_law(a), steel_contact_law(b))
        surface = self.composite()
        return None if surface is None else steel_contact_law(surface)

    def describe(self) -> dict[str, object]:
        """Ra of each body (None: smooth), and the RMS of the waviness in the gap when split, JSON-ready."""
        out = {"wheel_ra_um": None if self.wheel is None else self.wheel.ra_um,
               "rail_ra_um": None if self.rail is None else self.rail.ra_um}
        if self.waviness is not None:
            out["waviness_rms_um"] = self.waviness.rms_um
        return out


# ---------------------------------------------------------------------------
# analytic cross-checks
# ---------------------------------------------------------------------------
def bearing_area_closure_mm(surface: RoughSurface, nominal_pressure_mpa: np.ndarray,
                            hardness_mpa: float) -> np.ndarray:
    """Closure of a fully plastic contact: the surface truncated where ``A/A0 = p/H``.

    The rigid-plastic limit (Bowden & Tabor; Abbott-Firestone bearing
    curve): every contact spot carries the hardness, so the real area is
    ``p/H`` and the approach is the height from the highest summit to the
    level above which that fraction of the surface lies.
    """
    hard = check_positive("hardness_mpa", hardness_mpa)
    p = np.asarray(nominal_pressure_mpa, dtype=float)
    h = np.sort(surface.heights_um.ravel())[::-1]
    frac = np.clip(p / hard, 0.0, 1.0)
    k = np.clip(np.ceil(frac * h.size).astype(int) - 1, 0, h.size - 1)
    return 1e-3 * (h[0] - h[k])


def persson_contact_fraction(nominal_pressure_mpa: np.ndarray, contact_modulus_mpa: float,
                             rms_slope: float) -> np.ndarray:
    """Persson's (2001) elastic real contact fraction ``erf(sqrt 2 p / (E* h'))``.

    ``h'`` is the RMS slope of the surface; at small pressures this is
    ``A/A0 = sqrt(8/pi) p / (E* h')``.
    """
    e = check_positive("contact_modulus_mpa", contact_modulus_mpa)
    s = check_positive("rms_slope", rms_slope)
    p = np.asarray(nominal_pressure_mpa, dtype=float)
    return erf(math.sqrt(2.0) * p / (e * s))
