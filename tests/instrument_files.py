"""Writers of instrument files to their documented layouts, for the readers' tests.

Written from the layouts in :mod:`polishpath.psd.instruments` (Zygo's MetroPro
Reference Guide as the open readers document it; 4Sight's HDF5 as the open
FizCam/4Sight readers use it), independently of the reader's parsing: fields
are placed by their byte offsets / line numbers here, read by struct / token
position there.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

INVALID = 2147483640
PHASE_RES = {0: 4096, 1: 32768, 2: 131072}


def counts_for(z_nm: np.ndarray, wavelength_m: float, scale: float, obliquity: float, phase_res: int) -> np.ndarray:
    """Integer phase counts that give ``z_nm`` (NaN -> the invalid count)."""
    k = scale * obliquity * wavelength_m / PHASE_RES[phase_res] * 1e9
    c = np.where(np.isfinite(z_nm), np.round(np.nan_to_num(z_nm) / k), INVALID)
    return c.astype(np.int64)


def write_metropro_dat(path, z_nm, *, lateral_res_m=1e-4, wavelength_m=632.8e-9, scale=0.5, obliquity=1.0,
                       phase_res=1, header_format=1, sign=0, intensity_buckets=1, truncate=0) -> Path:
    """A MetroPro binary .dat: big-endian header (834 or 4096 bytes), intensity frames, then int32 phase rows."""
    z = np.asarray(z_nm, dtype=np.float64)
    h, w = z.shape
    hsize = 4096 if header_format == 3 else 834
    head = bytearray(hsize)
    magic = {1: 0x881B036F, 2: 0x881B0370, 3: 0x881B0371}[header_format]
    struct.pack_into(">I", head, 0, magic)
    struct.pack_into(">h", head, 4, header_format)
    struct.pack_into(">i", head, 6, hsize)
    iw, ih = (w, h) if intensity_buckets else (0, 0)
    struct.pack_into(">HHH", head, 52, iw, ih, intensity_buckets)
    struct.pack_into(">i", head, 60, 2 * iw * ih * intensity_buckets)
    struct.pack_into(">HH", head, 68, w, h)
    struct.pack_into(">i", head, 72, 4 * w * h)
    struct.pack_into(">ff", head, 164, scale, wavelength_m)
    struct.pack_into(">f", head, 176, obliquity)
    struct.pack_into(">f", head, 184, lateral_res_m)
    struct.pack_into(">h", head, 218, phase_res)
    struct.pack_into(">h", head, 232, sign)
    c = counts_for(-z if sign == 1 else z, wavelength_m, scale, obliquity, phase_res)
    intensity = np.full(iw * ih * intensity_buckets, 1000, dtype=">u2").tobytes()
    data = bytes(head) + intensity + c.astype(">i4").tobytes()
    Path(path).write_bytes(data[:len(data) - truncate] if truncate else data)
    return Path(path)


def write_zygo_ascii(path, z_nm, *, lateral_res_m=1e-4, wavelength_m=632.8e-9, scale=0.5, obliquity=1.0,
                     phase_res=1, sign=0, intensity=True, per_line=10) -> Path:
    """A Zygo ASCII data file, format 2: 14 header lines, '#', intensity block, '#', phase block, '#'."""
    z = np.asarray(z_nm, dtype=np.float64)
    h, w = z.shape
    iw, ih, nb = (w, h, 1) if intensity else (0, 0, 0)
    c = counts_for(-z if sign == 1 else z, wavelength_m, scale, obliquity, phase_res).ravel()
    lines = [
        "Zygo ASCII Data File - Format 2",
        '1 8 3 3 "Wed Jan 30 10:35:03 2013"',
        f"0 0 {iw} {ih} {nb} 255",
        f"1 1 {w} {h}",
        '"a comment"',
        '""',
        '"part 7"',
        f"1 {scale} {wavelength_m:.6e} 0 {obliquity} 0 {lateral_res_m:.6e} 719529",
        f'{w + 2} {h + 2} 4 0 651365 0 "Sm Aperture"',
        "0 0 1 3 1293 0 1 0.1 0 0",
        # PhaseRes PhaseAvgs MinimumAreaSize DisconAction DisconFilter ConnectionOrder RemoveTiltBias DataSign
        # CodeVType: the minimum area 7 as in a real NewView file, so a reader taking the wrong field fails
        f"{phase_res} 0 7 1 60 0 0 {sign} 0",
        '3 ""',
        "0 0",
        '"1X"',
        "#",
    ]

    def block(values):
        return [" ".join(str(int(v)) for v in values[i:i + per_line]) for i in range(0, len(values), per_line)]

    lines += block(np.full(iw * ih * nb, 1000)) + ["#"] + block(c) + ["#"]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def write_4d_h5(path, z_nm, *, wavelength="632.8 nm", xpix=None, sentinel=3.4028235e38, height_units=None,
                wedge=None, version=None) -> Path:
    """A 4Sight-style .h5: measurement0/genraw/data in waves (float32), masked pixels the float32 sentinel.

    ``height_units``, ``wedge`` and ``version`` add the attributes a real 4Sight 1.8 file carries
    (``height_units = "wv"``, ``wedge = 0.5``, the ``/4D`` group's ``_4Sight_version``); with ``height_units``
    "nm" the data are written in nm.
    """
    import h5py

    z = np.asarray(z_nm, dtype=np.float64)
    wl_nm = float(str(wavelength).split()[0]) if isinstance(wavelength, str) else float(wavelength)
    per = {"nm": 1.0, "um": 1e3}.get(height_units or "wv", wl_nm)
    waves = np.where(np.isfinite(z), z / per, sentinel).astype(np.float32)
    with h5py.File(path, "w") as f:
        g = f.create_group("measurement0").create_group("genraw")
        g.create_dataset("data", data=waves)
        g.attrs["wavelength"] = np.bytes_(wavelength) if isinstance(wavelength, str) else wavelength
        if xpix is not None:
            g.attrs["xpix"] = np.bytes_(xpix)
        if height_units is not None:
            g.attrs["height_units"] = np.bytes_(height_units)
        if wedge is not None:
            g.attrs["wedge"] = np.float32(wedge)
        if version is not None:
            f.create_group("4D").attrs["_4Sight_version"] = np.bytes_(version)
        f["measurement0"].create_dataset("Detectormask", data=np.isfinite(z).astype(np.uint8))
    return Path(path)


def write_4d_insight(path, z_nm, *, wavelength_nm=632.8, pixel_um=None, measurements=1) -> Path:
    """A 4D InSight .4D (HDF5): Measurement/SurfaceInWaves/Data in waves (float32, NaN without data), the
    wavelength as Measurement's WavelengthInNanometers, the pixel size as CalibratedFrames/image_0's
    PixelSizeInMicrons; ``measurements > 1`` writes Measurement/Measurement_<n> groups instead."""
    import h5py

    z = np.asarray(z_nm, dtype=np.float64)
    waves = (z / (wavelength_nm or 632.8)).astype(np.float32)
    with h5py.File(path, "w") as f:
        m = f.create_group("Measurement")
        groups = [m] if measurements == 1 else [m.create_group(f"Measurement_{k}") for k in range(measurements)]
        for g in groups:
            if wavelength_nm is not None:
                g.attrs["WavelengthInNanometers"] = np.float64(wavelength_nm)
            g.create_group("SurfaceInWaves").create_dataset("Data", data=waves)
            g.create_group("Intensity").create_dataset("Data", data=np.ones_like(waves))
            if pixel_um is not None:
                g.create_group("CalibratedFrames").create_group("image_0").attrs["PixelSizeInMicrons"] = \
                    np.float64(pixel_um)
    return Path(path)


def write_digital_surf(path, z_nm, *, dx_mm=0.0005, dy_mm=None, z_unit="µm", xy_unit="mm", bits=32,
                       studiable=None, acquisition=1, nonmeasured=True, inversion=0, compressed=False,
                       comment=b"", n_objects=1, truncate=0) -> Path:
    """A Digital Surf .sur / .pro (little-endian, 512-byte header; Gwyddion's surffile / SurfaceTopography's SUR
    layout): a 1D ``z_nm`` is a profile (studiable 1, one line), a 2D one a surface (studiable 2) with row 0 the
    file's first line. NaN -> the "not measured" code (smallest point - 2); ``compressed`` writes the
    DSCOMPRESSED form (one zlib stream behind a one-entry directory)."""
    import zlib

    z = np.atleast_2d(np.asarray(z_nm, dtype=np.float64))
    ny, nx = z.shape
    per_nm = {"m": 1e9, "mm": 1e6, "µm": 1e3, "um": 1e3, "nm": 1.0}[z_unit]
    finite = z[np.isfinite(z)]
    span = float(finite.max() - finite.min()) if finite.size else 1.0
    levels = 30000 if bits == 16 else 1 << 30
    step_nm = max(span, 1e-6) / levels  # heights quantised to span / levels
    c = np.round(np.nan_to_num(z - finite.min()) / step_nm).astype(np.int64) + 10
    zmin, zmax = int(c[np.isfinite(z)].min()), int(c[np.isfinite(z)].max())
    valid = np.isfinite(z)
    if inversion in (1, 2, 3):  # the file holds the inverted heights (same range): the reader inverts them back
        c = np.where(valid, zmax + zmin - c, c)
    if inversion == 2:  # ... and mirrored in x (2) or y (3)
        c, valid = c[:, ::-1], valid[:, ::-1]
    elif inversion == 3:
        c, valid = c[::-1], valid[::-1]
    c[~valid] = zmin - 2
    stored = c
    head = bytearray(512)
    head[0:12] = b"DSCOMPRESSED" if compressed else b"DIGITAL SURF"
    stype = studiable if studiable is not None else (1 if ny == 1 else 2)
    struct.pack_into("<hHhh", head, 12, 0, n_objects, 1, stype)
    head[20:24] = b"part"
    struct.pack_into("<hhhhh", head, 80, 0, acquisition, 1, 1 if nonmeasured else 0, 1)
    struct.pack_into("<h", head, 98, bits)
    struct.pack_into("<iiiiI", head, 100, zmin, zmax, nx, ny, nx * ny)
    per_xy = {"m": 1e-3, "mm": 1.0, "µm": 1e3, "um": 1e3, "nm": 1e6}[xy_unit]
    struct.pack_into("<fff", head, 120, dx_mm * per_xy, (dy_mm or dx_mm) * per_xy, step_nm / per_nm)
    for at, text in ((132, "X"), (148, "Y"), (164, "Z"), (180, xy_unit), (196, xy_unit), (212, z_unit),
                     (228, xy_unit), (244, xy_unit), (260, z_unit)):
        b = text.encode("latin-1")
        head[at:at + len(b)] = b
    struct.pack_into("<fff", head, 276, 1.0, 1.0, 1.0)
    struct.pack_into("<H", head, 290, inversion)
    struct.pack_into("<HH", head, 334, len(comment), 0)
    struct.pack_into("<f", head, 474, 12.5)  # a z offset (piston) the reader leaves out
    data = stored.astype("<i2" if bits == 16 else "<i4").tobytes()
    if compressed:
        zipped = zlib.compress(data)
        data = struct.pack("<III", 1, len(data), len(zipped)) + zipped
        struct.pack_into("<I", head, 324, len(data))
    out = bytes(head) + comment + data
    Path(path).write_bytes(out[:len(out) - truncate] if truncate else out)
    return Path(path)
