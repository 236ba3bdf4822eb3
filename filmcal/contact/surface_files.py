"""Measured surfaces in the formats instruments write: areal maps (ISO 25178-72 / ISO 5436-2 x3p) and stylus
line profiles (CSV).

An x3p file is a zip archive holding ``main.xml`` (the axes' increments in metres, the data type, the
matrix size and the link to the binary data) and the heights as little-endian binary (``D`` float64,
``F`` float32, ``L`` int32, ``I`` int16; integers scaled by the z axis's increment and offset; invalid
points NaN). The reader takes areal maps (``SUR``) and single profiles (``PRF``); it reads the XML with
the standard library's parser (no entities are expanded) and never executes anything from the file.

A line profile measured across a surface's lay (a turned wheel's turning marks, a ground rail's grinding
marks) describes the surface across it; along the lay the heights barely change. It becomes a ridged map,
the same profile on every row (`profile_surface`).

Every surface is levelled (a least-squares plane for maps, a line for profiles: ISO 4287's mean line
without form) and checked: a map must cover enough of the spectrum (at least 64 pixels and 50 um along
each side), resolve the asperities (pixels of at most 5 um) and carry no form (a curvature left after
levelling that exceeds its roughness, e.g. a wheel's radius measured along with it).
"""
from __future__ import annotations

import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

__all__ = ["read_surface_file", "surface_file_kind", "READING_OPTIONS", "read_x3p", "read_line_profile", "profile_surface", "MAX_PIXEL_UM",
           "MIN_PIXELS", "MIN_SIDE_UM", "MAX_MAP_PIXELS", "surface_file_shape", "check_map_pixels"]

#: The coarsest pixel (um) at which the asperities that carry the film's contact are resolved.
MAX_PIXEL_UM = 5.0
#: The largest height (um, either sign) a roughness measurement may hold before levelling: a tilt over a
#: 2 mm map plus Ra 30 um stays far below it; larger values are a unit error (heights in nm read as um).
MAX_HEIGHT_UM = 5000.0
#: The fewest pixels, and the shortest side (um), of a map that covers the spectrum's roll-off.
MIN_PIXELS = 64
MIN_SIDE_UM = 50.0
#: Largest x3p data file read (bytes): 2048 x 2048 float64 maps and a margin.
MAX_X3P_BYTES = 64 * 2**20

_TYPES = {"D": "<f8", "F": "<f4", "L": "<i4", "I": "<i2"}
#: The rows a line profile's ridged map gets (the profile repeated along the lay).
PROFILE_ROWS = 8
#: The most pixels of a map the boundary-element law is solved on (2048 x 2048): a law's time grows with its
#: pixels (about 90 s per million pixels against a film, `filmcal.contact.roughness.rough_law_cost`), so a larger
#: map is refused before it is read; crop it (the law is converged in the grid on 256-512 pixels of a
#: 200 um surface, `filmcal.contact.roughness`) or bin it to coarser pixels (at most `MAX_PIXEL_UM`) first.
MAX_MAP_PIXELS = 2048 * 2048


def _child(node, path: str, where: str):
    found = node.find(path)
    if found is None:
        raise ValueError(f"{where}: no {path} in main.xml (not an ISO 5436-2 x3p file?)")
    return found


def _number(node, path: str, where: str, default: float | None = None) -> float:
    found = node.find(path)
    if found is None or found.text is None:
        if default is not None:
            return default
        raise ValueError(f"{where}: no {path} in main.xml")
    try:
        return float(found.text)
    except ValueError:
        raise ValueError(f"{where}: {path} is not a number ({found.text!r})") from None


def _level(heights_um: np.ndarray, pixel_um: float, where: str) -> tuple[np.ndarray, float]:
    """Remove the least-squares plane (line for one row); refuse a form left over. Returns the levelled heights
    and the removed tilt's height range (um). Heights beyond `MAX_HEIGHT_UM` and a levelled Ra beyond the
    supported range are refused (a height unit or scale mistaken)."""
    from filmcal._validation import MAX_RA_UM, MIN_RA_UM

    worst = float(np.max(np.abs(heights_um))) if heights_um.size else 0.0
    if not worst <= MAX_HEIGHT_UM:  # NaN too
        raise ValueError(f"{where}: heights reach {worst:.3g} um; a roughness measurement lies within "
                         f"{MAX_HEIGHT_UM:g} um of its mean (check the height unit, or --roughness-height-scale)")
    n, m = heights_um.shape
    x = (np.arange(n) - 0.5 * (n - 1)) * pixel_um
    y = (np.arange(m) - 0.5 * (m - 1)) * pixel_um
    X, Y = np.meshgrid(x, y, indexing="ij")
    ones = np.ones_like(X)
    cols = [ones, X] + ([Y] if m > 1 else [])
    A = np.stack([c.ravel() for c in cols], axis=1)
    coef, *_ = np.linalg.lstsq(A, heights_um.ravel(), rcond=None)
    plane = (A @ coef).reshape(heights_um.shape)
    level = heights_um - plane
    # form: a quadratic along each axis that the plane leaves
    quad = [X * X] + ([Y * Y] if len(cols) == 3 else [])
    B = np.stack([c.ravel() for c in cols + quad], axis=1)
    qcoef, *_ = np.linalg.lstsq(B, heights_um.ravel(), rcond=None)
    fitted = (B @ qcoef).reshape(heights_um.shape)
    form = fitted - plane
    rms = float(np.sqrt(np.mean((heights_um - fitted) ** 2)))  # the roughness beside the form
    if np.ptp(form) > 4.0 * rms:  # a curvature spanning more than the roughness's +-2 rms band
        raise ValueError(f"{where}: not levelled: a curvature of {np.ptp(form):.3g} um remains over the map after "
                         f"removing its plane, more than its roughness (rms {rms:.3g} um); remove the form (the "
                         "body's radius) before use")
    ra = float(np.mean(np.abs(level - level.mean())))
    if not MIN_RA_UM <= ra <= MAX_RA_UM:
        raise ValueError(f"{where}: Ra {ra:.3g} um once levelled, outside the supported {MIN_RA_UM:g}-{MAX_RA_UM:g} um "
                         + ("(check the height unit, or --roughness-height-scale)" if ra > MAX_RA_UM
                            else "(a surface this smooth is smooth: give Ra 0 instead)"))
    return level, float(np.ptp(plane))


def _check_size(shape: tuple[int, ...], pixel_um: float, where: str, profile: bool = False) -> None:
    if pixel_um > MAX_PIXEL_UM:
        raise ValueError(f"{where}: too coarse: pixels of {pixel_um:.3g} um; the contact law needs the asperities "
                         f"resolved, at most {MAX_PIXEL_UM:g} um")
    sides = shape[:1] if profile else shape
    for count in sides:
        if count < MIN_PIXELS or count * pixel_um < MIN_SIDE_UM:
            raise ValueError(f"{where}: too small: {count} points over {count * pixel_um:.3g} um; at least "
                             f"{MIN_PIXELS} points and {MIN_SIDE_UM:g} um along each side")


def read_x3p(path: str | Path):
    """An areal map or a profile from an x3p file as a levelled `RoughSurface` (a profile: its ridged map)."""
    from filmcal.contact.roughness import RoughSurface

    path = Path(path)
    where = f"x3p file {path}"
    try:
        archive = zipfile.ZipFile(path)
    except FileNotFoundError:
        raise ValueError(f"{where}: not found") from None
    except (zipfile.BadZipFile, IsADirectoryError, OSError) as exc:
        raise ValueError(f"{where}: not an x3p archive ({exc})") from None
    with archive:
        try:
            root = ElementTree.fromstring(archive.read("main.xml"))
        except KeyError:
            raise ValueError(f"{where}: no main.xml in the archive") from None
        except ElementTree.ParseError as exc:
            raise ValueError(f"{where}: main.xml is not XML ({exc})") from None
        feature = (root.findtext("Record1/FeatureType") or "").strip()
        if feature not in ("SUR", "PRF"):
            raise ValueError(f"{where}: feature type {feature or 'missing'!r}: only areal maps (SUR) and "
                             "profiles (PRF) are read, not point clouds")
        axes = _child(root, "Record1/Axes", where)
        for axis in ("CX", "CY"):
            kind = (axes.findtext(f"{axis}/AxisType") or "").strip()
            if kind != "I":
                raise ValueError(f"{where}: axis {axis} is not incremental (AxisType {kind!r}): a gridded map "
                                 "is needed")
        dx = _number(axes, "CX/Increment", where)
        dy = _number(axes, "CY/Increment", where, default=dx)
        if not (dx > 0 and math.isfinite(dx)) or (feature == "SUR" and not math.isclose(dx, dy, rel_tol=1e-6)):
            raise ValueError(f"{where}: the map's pixels must be square (increments {dx:g} and {dy:g} m)")
        dtype = (axes.findtext("CZ/DataType") or "").strip()
        if dtype not in _TYPES:
            raise ValueError(f"{where}: z data type {dtype!r} (D, F, L or I)")
        z_scale = _number(axes, "CZ/Increment", where, default=1.0)
        z_offset = _number(axes, "CZ/Offset", where, default=0.0)
        dims = _child(root, "Record3/MatrixDimension", where)
        nx, ny, nz = (int(_number(dims, k, where)) for k in ("SizeX", "SizeY", "SizeZ"))
        if nz != 1 or nx < 1 or ny < 1:
            raise ValueError(f"{where}: matrix {nx} x {ny} x {nz}: one layer of heights is read")
        link = (root.findtext("Record3/DataLink/PointDataLink") or "").strip()
        if not link:
            raise ValueError(f"{where}: no binary data (heights listed in the XML are not read)")
        try:
            info = archive.getinfo(link)
        except KeyError:
            raise ValueError(f"{where}: the data file {link} is missing from the archive") from None
        expected = nx * ny * np.dtype(_TYPES[dtype]).itemsize
        if info.file_size != expected or info.file_size > MAX_X3P_BYTES:
            raise ValueError(f"{where}: {link} holds {info.file_size} bytes, expected {expected} for {nx} x {ny} "
                             f"{dtype} (at most {MAX_X3P_BYTES} bytes)")
        raw = np.frombuffer(archive.read(link), dtype=_TYPES[dtype])
    z = raw.astype(float) * (z_scale if dtype in ("L", "I") else 1.0) + (z_offset if dtype in ("L", "I") else 0.0)
    heights = 1e6 * z.reshape(ny, nx).T  # x fastest in the file; [ix, iy] here, um
    pixel_um = 1e6 * dx
    if not np.all(np.isfinite(heights)):
        bad = float(np.mean(~np.isfinite(heights)))
        raise ValueError(f"{where}: {100 * bad:.2g} % of the points are invalid (NaN): fill or crop them first")
    if feature == "PRF" or ny == 1:
        return profile_surface(heights[:, 0], pixel_um, f"x3p profile {path.name}")
    _check_size(heights.shape, pixel_um, where)
    level, tilt = _level(heights, pixel_um, where)
    return RoughSurface(level, pixel_um, f"x3p map {path.name} ({heights.shape[0]} x {heights.shape[1]} px at "
                                         f"{pixel_um:.3g} um, plane removed: tilt {tilt:.3g} um)")


def profile_surface(heights_um: np.ndarray, spacing_um: float, description: str = "line profile"):
    """A line profile measured across the lay as a ridged `RoughSurface`: the levelled profile on every row."""
    from filmcal.contact.roughness import RoughSurface

    z = np.asarray(heights_um, dtype=float).ravel()
    if not np.all(np.isfinite(z)):
        raise ValueError(f"{description}: heights must be finite")
    _check_size(z.shape, spacing_um, description, profile=True)
    level, tilt = _level(z[:, None], spacing_um, description)
    ridged = np.repeat(level, PROFILE_ROWS, axis=1)
    return RoughSurface(ridged, spacing_um, f"{description} across the lay ({z.size} points at {spacing_um:.3g} um, "
                                            f"line removed: tilt {tilt:.3g} um)")


def read_line_profile(path: str | Path):
    """A stylus line profile from a CSV with a header naming its position (``x_um`` or ``x_mm``) and height
    (``z_um`` or ``z_nm``) columns, measured across the lay; resampled to its median spacing."""
    import csv

    path = Path(path)
    where = f"line profile {path}"
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except FileNotFoundError:
        raise ValueError(f"{where}: not found") from None
    except (UnicodeDecodeError, IsADirectoryError) as exc:
        raise ValueError(f"{where}: not a CSV text file ({exc})") from None
    if not rows:
        raise ValueError(f"{where}: empty")
    header = [h.strip().lower() for h in rows[0]]
    scales = {"x_um": 1.0, "x_mm": 1e3, "z_um": 1.0, "z_nm": 1e-3}
    cols = {}
    for axis in ("x", "z"):
        names = [h for h in header if h in scales and h.startswith(axis)]
        if len(names) != 1:
            raise ValueError(f"{where}: needs one {axis} column named {axis}_um or "
                             f"{'x_mm' if axis == 'x' else 'z_nm'} in its header, found {rows[0]}")
        cols[axis] = (header.index(names[0]), scales[names[0]])
    try:
        data = np.array([[float(r[cols[a][0]]) * cols[a][1] for a in ("x", "z")] for r in rows[1:] if r],
                        dtype=float)
    except (ValueError, IndexError):
        raise ValueError(f"{where}: every row needs numbers in the x and z columns") from None
    if data.shape[0] < 2:
        raise ValueError(f"{where}: needs numbers in at least two rows, found {data.shape[0]}")
    bad = np.flatnonzero(~np.all(np.isfinite(data), axis=1))
    if bad.size:  # the row as a text editor numbers it (the header is line 1; blank lines are skipped)
        line = [n for n, r in enumerate(rows[1:], start=2) if r][bad[0]]
        more = f"; {bad.size} such rows in all" if bad.size > 1 else ""
        raise ValueError(f"{where}: line {line} is not finite ({', '.join(rows[line - 1])}){more}")
    x, z = data[:, 0], data[:, 1]
    if np.any(np.diff(x) <= 0):
        raise ValueError(f"{where}: positions must increase along the profile")
    spacing = float(np.median(np.diff(x)))
    grid = x[0] + spacing * np.arange(int(math.floor((x[-1] - x[0]) / spacing)) + 1)
    return profile_surface(np.interp(grid, x, z), spacing, f"line profile {path.name}")


def _is_line_profile_csv(path: Path) -> bool:
    with open(path, errors="replace") as fh:
        first = fh.readline(4096).lower()
    return any(name in first for name in ("x_um", "x_mm"))


def surface_file_shape(path: str | Path) -> tuple[int, int] | None:
    """The shape (pixels) of the map `read_surface_file` makes of a file, read from its header without
    decoding the heights (milliseconds); None when the file does not say (its reader then reports it).

    Images: the header's size. x3p: the matrix size (a profile: its points x `PROFILE_ROWS`). CSV: the first
    line's values times the lines, counted from the file's size and its first 64 KiB (an estimate for a
    height map; a line profile's points likewise, times `PROFILE_ROWS`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix in (".png", ".tif", ".tiff"):
            import warnings

            from PIL import Image

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                with Image.open(path) as img:
                    width, height = img.size
            return int(height), int(width)
        if suffix == ".x3p":
            with zipfile.ZipFile(path) as archive:
                root = ElementTree.fromstring(archive.read("main.xml"))
            dims = root.find("Record3/MatrixDimension")
            nx, ny = (int(float(dims.findtext(k))) for k in ("SizeX", "SizeY"))
            feature = (root.findtext("Record1/FeatureType") or "").strip()
            return (nx, PROFILE_ROWS) if feature == "PRF" or ny == 1 else (nx, ny)
        size = path.stat().st_size
        with open(path, "rb") as fh:
            head = fh.read(65536)
        lines = head.split(b"\n")
        if len(head) < size and len(lines) > 1:
            lines = lines[:-1]  # the last line read is cut
        lines = [line for line in lines if line.strip()]
        data = [line for line in lines if line[:1].strip(b" \t+-.0123456789eE,;") == b""]
        if not data:
            return None
        per_line = sum(len(line) + 1 for line in data) / len(data)
        rows = max(len(data), int(round(size / per_line)))
        profile = suffix == ".csv" and _is_line_profile_csv(path)
        cols = PROFILE_ROWS if profile else len(data[0].replace(b",", b" ").replace(b";", b" ").split())
        if len(head) < size and 0.75 * MAX_MAP_PIXELS < rows * cols < 1.33 * MAX_MAP_PIXELS:
            rows = _count_lines(path) - (len(lines) - len(data))  # near the cap: count (header lines off)
        return rows, cols
    except Exception:  # noqa: BLE001 - an unreadable header is the reader's to report
        return None


def _count_lines(path: Path) -> int:
    """Non-empty lines of a text file, read in 1 MiB blocks."""
    count, last = 0, b"\n"
    with open(path, "rb") as fh:
        while block := fh.read(2**20):
            count += block.count(b"\n") - block.count(b"\n\n")
            last = block[-1:]
    return count + (last != b"\n")


def check_map_pixels(path: str | Path, option: str = "roughness map", shape: tuple[int, int] | None = None) -> None:
    """Refuse a map of more than `MAX_MAP_PIXELS` pixels before it is read (`surface_file_shape`).

    Raises
    ------
    ValueError
        Naming `option`, the file, its size, the cap and the time a law on it would take.
    """
    from filmcal._memory import format_bytes, format_seconds
    from filmcal.contact.roughness import rough_law_cost

    shape = surface_file_shape(path) if shape is None else shape
    if shape is None or shape[0] * shape[1] <= MAX_MAP_PIXELS:
        return
    pixels = shape[0] * shape[1]
    cost = rough_law_cost(pixels)
    side = int(math.isqrt(MAX_MAP_PIXELS))
    raise ValueError(
        f"{option} {str(path)!r}: {shape[0]} x {shape[1]} = {pixels / 1e6:.3g} million pixels, more than the "
        f"{MAX_MAP_PIXELS / 1e6:.3g} million ({side} x {side}) the roughness law is solved on: one law on it "
        f"would take about {format_seconds(cost.seconds)} and {format_bytes(cost.bytes)}; crop it (e.g. to {side} x "
        f"{side}) or bin it to coarser pixels (at most {MAX_PIXEL_UM:g} um) first")


#: The options of `read_surface_file` each kind of file reads (the rest it has no use for).
READING_OPTIONS = {"x3p": (), "line profile": (), "csv map": ("pixel_um", "height_scale"),
                   "image": ("pixel_um", "height_range_um")}


def surface_file_kind(path: str | Path) -> str:
    """Which reader `read_surface_file` takes for `path`: a key of `READING_OPTIONS`.

    Raises
    ------
    ValueError
        For a JPEG: its lossy compression alters the heights.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".jpg", ".jpeg"):
        raise ValueError(f"roughness map {path}: a JPEG's lossy compression alters the heights; save the map as "
                         f"a 16-bit PNG or TIFF, a CSV of heights or an x3p file")
    if suffix == ".x3p":
        return "x3p"
    if suffix in (".png", ".tif", ".tiff"):
        return "image"
    return "line profile" if suffix == ".csv" and path.is_file() and _is_line_profile_csv(path) else "csv map"


def read_surface_file(path: str | Path, pixel_um: float | None = None, height_scale: float = 1.0,
                      height_range_um: float | None = None):
    """A measured surface by its file: x3p (map or profile), a CSV line profile (a header with x_um/x_mm and
    z_um/z_nm), a CSV height map (``pixel_um``, ``height_scale``) or a greyscale image (``pixel_um``,
    ``height_range_um``); levelled and checked (module notes). A map of more than `MAX_MAP_PIXELS` pixels is
    refused before it is decoded (`check_map_pixels`)."""
    from filmcal.contact.roughness import RoughSurface

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"roughness map {path}: not found")
    kind = surface_file_kind(path)
    check_map_pixels(path)
    if kind == "x3p":
        return read_x3p(path)
    if kind == "line profile":
        return read_line_profile(path)
    if pixel_um is None:
        raise ValueError(f"roughness map {path}: a height map needs its pixel size (--roughness-pixel-um)")
    if kind == "image" and height_range_um is None:
        raise ValueError(f"roughness map {path}: an image needs its height range (--roughness-height-range-um)")
    try:
        surface = RoughSurface.from_image(path, pixel_um, height_range_um) if kind == "image" \
            else RoughSurface.from_csv(path, pixel_um, height_scale)
    except ValueError as exc:
        raise ValueError(str(exc) if str(path) in str(exc) else f"roughness map {path}: {exc}") from None
    _check_size(surface.heights_um.shape, surface.pixel_um, f"roughness map {path}")
    level, _ = _level(surface.heights_um, surface.pixel_um, f"roughness map {path}")
    return RoughSurface(level, surface.pixel_um, surface.description)
