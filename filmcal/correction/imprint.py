"""Scanned film imprints: the stained area, its outline and its uncertainty.

A Prescale imprint is scanned (PNG, TIFF or JPEG) and read as follows:

1. Stain intensity in [0, 1] (0 = paper, 1 = fully stained), see
   `stain_intensity`. A colour scan is unmixed by the dye's colour: each
   channel's optical density ``-log10(value / white)`` is, by Beer-Lambert,
   a sum of the densities of what lies on the page, and three colours span
   what a scanned sheet holds: the Prescale dye (a red-magenta that absorbs
   green and blue light and hardly any red), neutral grey (paper shading,
   pencil and black pen, the scanner's lid) and yellow (masking tape, aged
   paper). The dye's share, solved for per pixel, is independent of the
   other two, and blue ink comes out below zero (it absorbs red, the dye
   does not); it is clipped at zero and returned as the green-channel
   darkening the dye alone would cause on white paper. A greyscale scan has
   only the luminance: ``1 - L``.
2. Threshold: Otsu's (1979) threshold of the intensity histogram (the level
   that maximises the variance between the two classes it separates), or one
   given by the user.
3. Regions: connected stained pixels (8-connectivity) of at least
   ``min_region_mm2`` are kept, so that dust and specks drop out while both
   patches of a two-point wheel-rail contact stay; holes are filled
   (unstained spots inside the patch belong to the contact).
4. Outline: the contour of the intensity at the threshold, restricted to the
   kept regions, with linear interpolation between pixel centres (marching
   squares): sub-pixel where the scanner blurs the edge over a few pixels.
   The area is the area the outline encloses.

Coordinates: x to the right, y up, in mm, origin at the lower-left corner of
the image (the pixel in the last row and first column has its centre at
``(h/2, h/2)``, ``h`` the pixel size). Outlines are closed polygons (the
first vertex repeated at the end), counter-clockwise.

Area uncertainty
----------------
Two parts, added in quadrature:

* *pixel size*: an edge is located to within a pixel; a shift ``u`` of the
  whole outline, uniform in ``[-h/2, h/2]``, changes the area by ``P u``
  (``P`` the perimeter), with standard deviation ``P h / sqrt(12)``. This is
  the correlated (worst) case; independent errors along the edge would
  average out further.
* *threshold*: where the stain ends is a matter of definition when its colour
  fades towards the edge. The threshold is taken as uncertain by 10 % of the
  contrast between the stained and the paper class means (the two Otsu
  classes); half the difference of the areas found at the threshold lowered
  and raised by that much is the standard uncertainty. A sharp edge gives a
  small term, a gradually fading one a large term.
"""
from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from filmcal._errors import DamagedFileError, damaged
from filmcal._validation import SCAN_PIXEL_MM_BOUNDS, as_finite, check_range
from filmcal.correction.outline import _signed_area_mm2, outline_centroid_mm, outline_perimeter_mm

__all__ = ["Imprint", "read_imprint", "measure_imprint", "stain_intensity", "intensity_noise", "otsu_threshold",
           "load_scan"]

MM_PER_INCH = 25.4
# Largest scan read (pixels): 30 million is a 600 dpi scan of 23 cm x 23 cm or a 1200 dpi scan of
# 11.6 cm x 11.6 cm. Measuring takes about 45 bytes per pixel (1.4 GB at the limit). Larger files are
# refused from their header, before they are decoded (decompression bombs, mistaken huge images).
MAX_IMPRINT_PIXELS = 30_000_000
MIN_METADATA_DPI = 25.0  # file resolutions below this are placeholders (e.g. 1 dpi in a TIFF without one)
THRESHOLD_SPREAD = 0.1  # threshold uncertainty as a fraction of the stain-paper contrast
_EPS = 1e-9
#: Optical densities (R, G, B) of the three colours a scanned sheet is unmixed into, each scaled to its green
#: density. The dye's and the tape's are the mean over the dense cores and over the masking tape of a real
#: 200 dpi flatbed scan of Prescale LW imprints (tests/data/scans), against the paper beside them.
DYE_OPTICAL_DENSITY = (0.026, 1.0, 0.86)
NEUTRAL_OPTICAL_DENSITY = (1.0, 1.0, 1.0)
YELLOW_OPTICAL_DENSITY = (0.12, 0.33, 1.0)
# The dye's (green) density is this row dotted with a pixel's densities: the first row of the inverse of the
# matrix whose columns are the three colours.
_DYE_UNMIXING = tuple(float(w) for w in np.linalg.inv(
    np.column_stack([DYE_OPTICAL_DENSITY, NEUTRAL_OPTICAL_DENSITY, YELLOW_OPTICAL_DENSITY]))[0])


@dataclass
class Imprint:
    """The stained area of a scanned imprint.

    Attributes
    ----------
    area_mm2 : float
        Area enclosed by the outlines.
    area_std_mm2 : float
        Standard uncertainty of the area from the pixel size and the threshold
        (module notes), the two parts in ``area_std_pixel_mm2`` and
        ``area_std_threshold_mm2``.
    outlines_mm : list of ndarray
        Closed counter-clockwise polygons, ``(n, 2)`` arrays of (x, y) in mm,
        one per stained region (image frame, module notes).
    centroid_mm : ndarray, shape (2,)
        Area centroid of the stained regions.
    perimeter_mm : float
        Total length of the outlines.
    pixel_size_mm : float
    pixel_size_source : str
        "dpi", "mm_per_pixel", "file metadata" or "given".
    threshold : float
        Stain intensity (0-1) above which a pixel counts as stained.
    contrast : float
        Mean intensity of the stained class minus that of the paper class.
    mask : ndarray of bool
        Stained pixels after region selection and hole filling, indexed
        ``[row, column]`` as stored (row 0 at the top of the image).
    """

    area_mm2: float
    area_std_mm2: float
    area_std_pixel_mm2: float
    area_std_threshold_mm2: float
    outlines_mm: list[np.ndarray] = field(repr=False)
    centroid_mm: np.ndarray
    perimeter_mm: float
    pixel_size_mm: float
    pixel_size_source: str
    threshold: float
    contrast: float
    mask: np.ndarray = field(repr=False)

    @property
    def n_regions(self) -> int:
        """Number of stained regions (outlines)."""
        return len(self.outlines_mm)

    @property
    def equivalent_radius_mm(self) -> float:
        """Radius of the circle of the same area, ``sqrt(A / pi)``."""
        return math.sqrt(self.area_mm2 / math.pi)

    def to_dict(self) -> dict:
        """Scalar summaries for JSON (no outlines, no mask)."""
        return {"area_mm2": self.area_mm2, "area_std_mm2": self.area_std_mm2,
                "area_std_pixel_mm2": self.area_std_pixel_mm2,
                "area_std_threshold_mm2": self.area_std_threshold_mm2,
                "equivalent_radius_mm": self.equivalent_radius_mm, "n_regions": self.n_regions,
                "centroid_mm": [float(c) for c in self.centroid_mm], "perimeter_mm": self.perimeter_mm,
                "pixel_size_mm": self.pixel_size_mm, "pixel_size_source": self.pixel_size_source,
                "threshold": self.threshold, "contrast": self.contrast}


# ---------------------------------------------------------------------------
# Intensity and threshold
# ---------------------------------------------------------------------------

def _full_scale(pixels: np.ndarray) -> float:
    """The value of white for an array of pixel values."""
    if pixels.dtype == np.uint8:
        return 255.0
    if pixels.dtype == np.uint16:
        return 65535.0
    if np.issubdtype(pixels.dtype, np.integer):
        if pixels.min() < 0 or pixels.max() > 65535:
            raise ValueError("integer pixel values must lie in 0-65535 (8 or 16 bits)")
        return 65535.0
    if np.issubdtype(pixels.dtype, np.floating):
        if not np.all(np.isfinite(pixels)) or pixels.min() < 0.0 or pixels.max() > 1.0:
            raise ValueError("floating-point pixel values must be finite and lie in [0, 1]")
        return 1.0
    raise ValueError(f"unsupported pixel type {pixels.dtype}")


def stain_intensity(pixels) -> np.ndarray:
    """Stain intensity in [0, 1] of scanned pixels (0 = white paper).

    Parameters
    ----------
    pixels : array_like
        ``(rows, columns)`` greyscale, ``(rows, columns, 2)`` greyscale with
        alpha, ``(rows, columns, 3)`` RGB or ``(rows, columns, 4)`` RGBA;
        8-bit, 16-bit, float in [0, 1], or bool (True = white).

    Returns
    -------
    ndarray of float32, shape (rows, columns)
        For colour, ``1 - 10**(-c)`` with ``c`` the dye's green optical
        density unmixed from `DYE_OPTICAL_DENSITY`, `NEUTRAL_OPTICAL_DENSITY`
        and `YELLOW_OPTICAL_DENSITY` (module notes): tape, pencil, black pen
        and blue ink read as paper. ``1 - L`` for greyscale. Transparent
        pixels count as white paper.
    """
    pixels = np.asarray(pixels)
    if pixels.dtype == bool:
        pixels = pixels.astype(np.uint8) * 255
    if pixels.ndim == 2:
        channels = pixels[:, :, None]
    elif pixels.ndim == 3 and pixels.shape[2] in (2, 3, 4):
        channels = pixels
    else:
        raise ValueError(f"pixels must have shape (rows, columns) or (rows, columns, 2|3|4), got {pixels.shape}")
    if min(channels.shape[:2]) < 3:
        raise ValueError(f"the image must be at least 3 x 3 pixels, got {channels.shape[0]} x {channels.shape[1]}")
    scale = np.float32(_full_scale(channels))
    n = channels.shape[2]
    alpha = channels[:, :, -1].astype(np.float32) / scale if n in (2, 4) else None
    if n < 3:
        value = channels[:, :, 0].astype(np.float32) / scale
        if alpha is not None:  # composite over white paper
            value = alpha * value + (1.0 - alpha)
        return 1.0 - value
    density = np.zeros(channels.shape[:2], dtype=np.float32)
    for weight, value in zip(_DYE_UNMIXING, _colour_values(channels)):
        density -= np.float32(weight) * np.log10(value)
    return -np.expm1(np.float32(-math.log(10.0)) * np.maximum(density, 0.0))


def _colour_values(channels: np.ndarray):
    """Each colour channel of RGB(A) pixels as a fraction of white, composited over white paper where
    transparent and floored at half a level (the logarithm of `stain_intensity` stays finite)."""
    scale = np.float32(_full_scale(channels))
    floor = np.float32(0.5 / scale if scale > 1 else 1.0 / 65535.0)
    alpha = channels[:, :, 3].astype(np.float32) / scale if channels.shape[2] == 4 else None
    for k in range(3):
        value = channels[:, :, k].astype(np.float32) / scale
        if alpha is not None:
            value = alpha * value + (1.0 - alpha)
        yield np.maximum(value, floor)


def intensity_noise(pixels) -> float:
    """Standard deviation of blank paper's `stain_intensity` caused by the scan's own noise (a colour scan).

    Each channel's noise is read from the differences of horizontally neighbouring pixels, whose median
    absolute deviation divided by sqrt(2) is a pixel's standard deviation where the page itself is smooth
    (paper, tape, the inside of a core: most of a page; the edges and dots are too few to move the median).
    It is carried through `stain_intensity`'s unmixing at the page's median colour (first order: each
    channel's density moves by sigma / (ln 10 value)). A clean or JPEG-smoothed 8-bit scan, whose neighbours
    mostly agree to the level, reads 0.

    Parameters
    ----------
    pixels : array_like
        ``(rows, columns, 3)`` RGB or ``(rows, columns, 4)`` RGBA, as `stain_intensity` takes them.
    """
    pixels = np.asarray(pixels)
    if pixels.ndim != 3 or pixels.shape[2] not in (3, 4) or min(pixels.shape[:2]) < 3:
        raise ValueError(f"the noise of a colour scan is read from (rows, columns, 3|4) pixels, at least 3 x 3, "
                         f"got {pixels.shape}")
    rows = pixels[::max(1, pixels.shape[0] // 512)]  # some 512 whole rows: the median is settled long before
    variance = 0.0
    for weight, value in zip(_DYE_UNMIXING, _colour_values(rows)):
        steps = np.diff(value, axis=1)
        sigma = 1.4826 * float(np.median(np.abs(steps - np.median(steps)))) / math.sqrt(2.0)
        variance += (weight * sigma / (math.log(10.0) * float(np.median(value)))) ** 2
    # stain_intensity = 1 - 10**(-c): its slope ln 10 (1 - intensity) at the paper's intensity
    paper = float(np.median(stain_intensity(rows)))
    return math.log(10.0) * (1.0 - paper) * math.sqrt(variance)


def otsu_threshold(values, bins: int = 256) -> float:
    """Otsu's threshold of values in [0, 1]: the level maximising the between-class variance.

    Parameters
    ----------
    values : array_like
        Intensities in [0, 1].
    bins : int
        Histogram bins over [0, 1].

    Returns
    -------
    float
        The threshold; values above it form the upper class. Where several
        levels give the same maximum (an empty gap between two modes), the
        middle of that run of levels.

    Raises
    ------
    ValueError
        If all values are equal (no two classes to separate).
    """
    x = np.asarray(values, dtype=float).ravel()
    if x.size == 0 or not np.all(np.isfinite(x)) or x.min() < 0.0 or x.max() > 1.0:
        raise ValueError("values must be finite and lie in [0, 1]")
    bins = int(check_range("bins", bins, 2, 1 << 16, low_open=False, high_open=False))
    if x.max() - x.min() <= _EPS:
        raise ValueError("the image has no contrast: all intensities are equal")
    counts, edges = np.histogram(x, bins=bins, range=(0.0, 1.0))
    p = counts / counts.sum()
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(p)[:-1]                      # weight of the lower class for a cut after bin k
    m0 = np.cumsum(p * centres)[:-1]
    mean = float(np.sum(p * centres))
    w1 = 1.0 - w0
    valid = (w0 > 0) & (w1 > 0)
    between = np.zeros_like(w0)
    between[valid] = (mean * w0[valid] - m0[valid]) ** 2 / (w0[valid] * w1[valid])
    best = np.flatnonzero(between >= between.max() * (1.0 - 1e-12))
    k = 0.5 * (best[0] + best[-1])              # the cut lies after bin k
    return float((k + 1.0) / bins)


# ---------------------------------------------------------------------------
# Segmentation and outline
# ---------------------------------------------------------------------------

def _stained_regions(intensity: np.ndarray, threshold: float, min_pixels: float) -> np.ndarray:
    """Pixels above the threshold in regions of at least ``min_pixels``, holes filled."""
    from scipy import ndimage

    labels, n = ndimage.label(intensity > threshold, structure=np.ones((3, 3), dtype=int))
    if n == 0:
        return np.zeros(intensity.shape, dtype=bool)
    sizes = np.bincount(labels.ravel())
    keep = sizes >= min_pixels
    keep[0] = False
    return ndimage.binary_fill_holes(keep[labels])


def _contour_rings(intensity: np.ndarray, mask: np.ndarray, threshold: float,
                   pixel_mm: float) -> list[np.ndarray]:
    """Sub-pixel outline of ``mask`` from the intensity at the threshold (image frame, mm).

    The field is the intensity, lifted just above the threshold inside the
    mask and lowered just below it outside, so the contour separates exactly
    the mask from the rest, placed along each pixel-to-pixel step where the
    intensity crosses the threshold.
    """
    import contourpy

    z = np.where(mask, np.maximum(intensity, threshold + _EPS), np.minimum(intensity, threshold - _EPS))
    z = np.pad(z[::-1], 1, constant_values=min(0.0, threshold - _EPS))  # rows bottom-up, closed by paper
    x = (np.arange(z.shape[1]) - 0.5) * pixel_mm
    y = (np.arange(z.shape[0]) - 0.5) * pixel_mm
    gen = contourpy.contour_generator(x, y, z, line_type=contourpy.LineType.Separate)
    rings = [np.asarray(r, dtype=float) for r in gen.lines(threshold) if len(r) >= 4]
    return [r for r in rings if abs(_signed_area_mm2(r)) > 0.0]


def _area_at(intensity: np.ndarray, threshold: float, min_pixels: float, pixel_mm: float) -> float:
    mask = _stained_regions(intensity, threshold, min_pixels)
    if not mask.any():
        return 0.0
    return sum(_signed_area_mm2(r) for r in _contour_rings(intensity, mask, threshold, pixel_mm))


def _class_means(intensity: np.ndarray, threshold: float) -> tuple[float, float]:
    above = intensity > threshold
    if above.all() or not above.any():
        raise ValueError(f"no stain found: threshold {threshold:g} leaves no "
                         f"{'paper' if above.all() else 'stained'} pixels")
    return float(intensity[~above].mean()), float(intensity[above].mean())


def measure_imprint(intensity, pixel_size_mm: float, *, threshold: float | None = None,
                    min_region_mm2: float = 1.0, min_contrast: float = 0.1,
                    pixel_size_source: str = "given") -> Imprint:
    """The stained area and outline of a stain-intensity image.

    Parameters
    ----------
    intensity : array_like, shape (rows, columns)
        Stain intensity in [0, 1] (`stain_intensity`), row 0 at the top.
    pixel_size_mm : float
        Edge length of a (square) pixel (mm), 0.001-1 (`SCAN_PIXEL_MM_BOUNDS`: 25400 to 25.4 dpi).
    threshold : float, optional
        Intensity above which a pixel is stained, in [0, 1]; Otsu's by default.
    min_region_mm2 : float
        Smallest stained region kept (mm^2, >= 0): specks below it are dust.
    min_contrast : float
        Smallest difference of the mean intensities of the stained and the
        paper class, in [0, 1): below it the image holds no stain (a blank
        scan's noise split in two).
    pixel_size_source : str
        Recorded in the result.

    Returns
    -------
    Imprint

    Raises
    ------
    ValueError
        For a bad parameter, an image without stain, no region of at least
        ``min_region_mm2``, or a stain that touches the image border (the
        imprint is cut off).
    """
    intensity = np.asarray(intensity, dtype=float)
    if intensity.ndim != 2 or min(intensity.shape) < 3:
        raise ValueError(f"intensity must be a 2-D image of at least 3 x 3 pixels, got shape {intensity.shape}")
    if not np.all(np.isfinite(intensity)) or intensity.min() < 0.0 or intensity.max() > 1.0:
        raise ValueError("intensity must be finite and lie in [0, 1]")
    h = check_range("pixel_size_mm", pixel_size_mm, *SCAN_PIXEL_MM_BOUNDS, low_open=False, high_open=False)
    min_region = as_finite("min_region_mm2", min_region_mm2)
    if min_region < 0.0:
        raise ValueError(f"min_region_mm2 must be >= 0, got {min_region:g}")
    min_contrast = check_range("min_contrast", min_contrast, 0.0, 1.0, low_open=False)
    t = otsu_threshold(intensity) if threshold is None else check_range("threshold", threshold, 0.0, 1.0, low_open=False, high_open=False)
    paper, stain = _class_means(intensity, t)
    contrast = stain - paper
    if contrast < min_contrast:
        raise ValueError(f"no stain found: the stained class is only {contrast:.3f} darker than the paper "
                         f"(min_contrast {min_contrast:g})")
    min_pixels = max(1.0, min_region / h**2)
    mask = _stained_regions(intensity, t, min_pixels)
    if not mask.any():
        raise ValueError(f"no stained region of at least min_region_mm2 = {min_region:g} mm2 at threshold {t:.3f}")
    if mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any():
        raise ValueError("the stain touches the image border: the imprint is cut off; scan it with a margin "
                         "of paper around it")
    rings = _contour_rings(intensity, mask, t, h)
    area = sum(_signed_area_mm2(r) for r in rings)
    perimeter = outline_perimeter_mm(rings)
    spread = THRESHOLD_SPREAD * contrast
    lower = _area_at(intensity, max(t - spread, _EPS), min_pixels, h)
    upper = _area_at(intensity, min(t + spread, 1.0 - _EPS), min_pixels, h)
    std_threshold = 0.5 * abs(lower - upper)
    std_pixel = perimeter * h / math.sqrt(12.0)
    return Imprint(
        area_mm2=float(area), area_std_mm2=float(math.hypot(std_pixel, std_threshold)),
        area_std_pixel_mm2=float(std_pixel), area_std_threshold_mm2=float(std_threshold),
        outlines_mm=[np.vstack([r, r[:1]]) if not np.array_equal(r[0], r[-1]) else r for r in rings],
        centroid_mm=outline_centroid_mm(rings), perimeter_mm=perimeter, pixel_size_mm=h,
        pixel_size_source=pixel_size_source, threshold=float(t), contrast=float(contrast), mask=mask)


# ---------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------

class ScanResolutionWarning(UserWarning):
    """A resolution given on the command line differs from the one the scan's file records."""


def _pixel_size(dpi, mm_per_pixel, info: dict, path: Path) -> tuple[float, str]:
    """Pixel size (mm) from exactly one of dpi, mm_per_pixel, or the file's resolution."""
    if dpi is not None and mm_per_pixel is not None:
        raise ValueError("give either dpi or mm_per_pixel, not both")
    meta = info.get("dpi")
    xd = yd = float("nan")
    if meta is not None:
        try:
            xd, yd = (float(v) for v in meta)
        except (TypeError, ValueError):
            xd = yd = float("nan")
    recorded = math.isfinite(xd) and math.isfinite(yd) and min(xd, yd) >= MIN_METADATA_DPI
    if dpi is not None or mm_per_pixel is not None:
        h = (MM_PER_INCH / check_range("dpi", dpi, MM_PER_INCH / SCAN_PIXEL_MM_BOUNDS[1],
                                       MM_PER_INCH / SCAN_PIXEL_MM_BOUNDS[0], low_open=False, high_open=False)
             if dpi is not None else check_range("mm_per_pixel", mm_per_pixel, *SCAN_PIXEL_MM_BOUNDS,
                                                 low_open=False, high_open=False))
        # written by software, not by a scanner (nothing recorded: nothing to compare)
        software_default = recorded and round(0.5 * (xd + yd)) in (72, 96)
        if recorded and not software_default and abs(h / (MM_PER_INCH / (0.5 * (xd + yd))) - 1.0) > 0.01:
            import warnings

            warnings.warn(ScanResolutionWarning(
                f"{path.name} records {0.5 * (xd + yd):g} dpi; read at the {MM_PER_INCH / h:g} dpi given instead "
                f"(areas scale with the square of the pixel size: x{(h * 0.5 * (xd + yd) / MM_PER_INCH) ** 2:.3g})"),
                stacklevel=3)
        return h, "dpi" if dpi is not None else "mm_per_pixel"
    if meta is not None:
        if recorded:
            if abs(xd - yd) > 1e-3 * max(xd, yd):
                raise ValueError(f"{path.name} has non-square pixels ({xd:g} x {yd:g} dpi): resample it to "
                                 "square pixels, or give dpi or mm_per_pixel")
            return MM_PER_INCH / (0.5 * (xd + yd)), "file metadata"
    raise ValueError(f"{path.name} has no resolution metadata: give the pixel size as dpi or mm_per_pixel")


def _image_pixels(image) -> np.ndarray:
    """Pixel values of a Pillow image as an array `stain_intensity` takes."""
    mode = image.mode
    if mode in ("1", "L", "LA", "RGB", "RGBA", "I;16", "I;16L", "I;16B", "I", "F"):
        pixels = np.asarray(image)
    else:  # CMYK, YCbCr, LAB, HSV, ...
        pixels = np.asarray(image.convert("RGB"))
    if mode in ("I;16", "I;16L", "I;16B"):
        pixels = pixels.astype(np.uint16)
    return pixels


class _SizeRefused(ValueError):
    """A scan with too few or too many pixels: a readable file, refused from its header before decoding."""


def load_scan(path, max_pixels: int = MAX_IMPRINT_PIXELS) -> tuple[np.ndarray, dict]:
    """The pixels (as `stain_intensity` takes them) and the metadata of a scan, verified before decoding.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    filmcal._errors.DamagedFileError
        (a `ValueError`) for a file that is not an image, is truncated or
        damaged.
    ValueError
        For a scan of more than ``max_pixels`` pixels (refused from its header, before it is decoded) or a
        palette image.
    """
    import warnings

    from PIL import Image

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"scan not found: {path}")
    try:
        with warnings.catch_warnings():
            # Pillow warns above its own pixel limit; the smaller limit below refuses first
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as image:
                width, height = image.size
                if width < 2 or height < 2:
                    raise _SizeRefused(f"{path.name}: {width} x {height} pixels is not a scan of an imprint")
                if width * height > max_pixels:
                    raise _SizeRefused(f"{path.name}: {width} x {height} pixels; a scan has at most "
                                       f"{max_pixels / 1e6:g} million pixels (a whole A4 page at 600 dpi is 35 "
                                       "million): crop it or scan it at a lower resolution")
                mode = image.mode
                if mode not in ("P", "PA"):  # refused below, without decoding
                    image.load()
                    info = dict(image.info)
                    pixels = _image_pixels(image)
    except (DamagedFileError, _SizeRefused):
        raise
    except Image.DecompressionBombError as exc:
        raise damaged(path, exc) from None
    except MemoryError:
        raise DamagedFileError(path, "too large to decode in the available memory: crop or downsample it") from None
    except (OSError, SyntaxError, ValueError, EOFError, struct.error, zlib.error) as exc:
        # UnidentifiedImageError (not an image), "image file is truncated", broken chunks
        if "cannot identify image file" in str(exc):
            raise DamagedFileError(path, "not an image Pillow can read (PNG, TIFF or JPEG expected)") from None
        raise damaged(path, exc) from None
    if mode in ("P", "PA"):
        raise ValueError(f"{path.name} is an indexed-colour (palette) image: its few quantised colours cannot "
                         "carry the dye's density; save the scan as true colour (RGB PNG, TIFF or JPEG)")
    return pixels, info


def read_imprint(path, *, dpi: float | None = None, mm_per_pixel: float | None = None,
                 threshold: float | None = None, min_region_mm2: float = 1.0,
                 min_contrast: float = 0.1) -> Imprint:
    """Read a scanned imprint (PNG, TIFF or JPEG) into its stained area and outline.

    Parameters
    ----------
    path : str or Path
        The scan.
    dpi, mm_per_pixel : float, optional
        The scan's resolution: at most one of them. Without either, the
        file's own resolution metadata is used; a ValueError if it has none
        (or less than 25 dpi, a placeholder such as the 1 dpi of a TIFF
        written without a resolution). Software other than a scanner may
        write a default (72 or 96 dpi): give the resolution when in doubt.
    threshold, min_region_mm2, min_contrast
        See `measure_imprint`.

    Returns
    -------
    Imprint
        In the image frame: x to the right, y up, mm, origin at the image's
        lower-left corner.

    Raises
    ------
    FileNotFoundError, filmcal._errors.DamagedFileError
        As `load_scan` (at most `MAX_IMPRINT_PIXELS` pixels).
    ValueError
        For a missing or doubly given pixel size, or an image without a
        usable stain (`measure_imprint`).
    """
    path = Path(path)
    pixels, info = load_scan(path)
    pixel_mm, source = _pixel_size(dpi, mm_per_pixel, info, path)
    try:
        return measure_imprint(stain_intensity(pixels), pixel_mm, threshold=threshold,
                               min_region_mm2=min_region_mm2, min_contrast=min_contrast, pixel_size_source=source)
    except ValueError as exc:  # said of the scan it is about
        raise type(exc)(str(exc) if str(path) in str(exc) else f"scan {path}: {exc}") from None
