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
