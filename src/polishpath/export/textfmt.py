"""Numbers to text in bulk: the formatting every writer shares (compiled loops into a bytes buffer).

Two kernels, each writing whole rows of numbers into a ``uint8`` buffer that the
caller writes to the file in large chunks:

* :func:`fixed_point_rows` -- fixed-point numbers (``%.{d}f`` of the value
  rounded to ``d`` decimals, with no ``-0``), each optionally after an address
  letter (G-code words ``X1.2345``) and present or not per row (modal G-code
  leaves out the words that did not change). The value is printed from the
  integer ``rint(x * 10^d)``, exactly the digits ``"%.{d}f" % (np.round(x, d) + 0.0)``
  prints while ``|x| < 2^52 / 10^(d+1)`` (:func:`fixed_point_exact`; beyond,
  the callers fall back to Python's ``%``).
* :func:`csv_rows` -- ``%d`` integer and ``%.17g`` float columns. The 17
  significant digits are correctly rounded from a double-double product of x
  and a power of ten (~106 bits, an error far below the last digit); where the
  product cannot tell the rounding (within 1e-6 of a tie) and outside
  1e-280..1e280, the C library's ``strfromd`` (C23, glibc >= 2.25; correctly
  rounded like Python's ``%``) prints the number. The same text as Python's
  ``%`` (checked in tests/test_export.py). Where the C library has no
  ``strfromd`` (:data:`HAVE_STRFROMD` false) the callers use Python's ``%``.

Written by hand because no library formats numpy arrays to text in bulk:
``numpy.savetxt`` and ``np.char.mod`` call Python's ``%`` once per row or value
(8-15 MB/s here); these loops run at 50-150 MB/s (benchmarks/bench_writers.py).
"""

from __future__ import annotations

import ctypes
import ctypes.util

import numba
from .. import _numba_cache  # noqa: F401  (numba's cache keyed on the kernels called)
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["fixed_point_rows", "csv_rows", "fixed_point_exact", "fixed_text", "HAVE_STRFROMD", "FIXED_MAX_CHARS",
           "CSV_FLOAT_MAX_CHARS", "NO_LEADING_ZERO", "NO_TRAILING_ZEROS", "KEEP_POINT"]


def _has_strfromd() -> bool:
    try:
        return hasattr(ctypes.CDLL(ctypes.util.find_library("c") or None), "strfromd")
    except OSError:  # pragma: no cover - no C library to ask
        return False


#: whether the C library has ``strfromd`` (the %.17g kernel needs it)
HAVE_STRFROMD = _has_strfromd()
#: most characters of one fixed-point number at 9 decimals (sign, 19 digits, point, 9 digits) + letter + separator
FIXED_MAX_CHARS = 32
#: most characters of one %.17g number ("-1.2345678901234567e-308") + separator
CSV_FLOAT_MAX_CHARS = 26


def fixed_point_exact(values: np.ndarray, decimals: int) -> bool:
    """Whether :func:`fixed_point_rows` prints exactly Python's ``%.{d}f`` of ``values`` rounded (finite, not huge)."""
    v = np.asarray(values)
    if v.size == 0:
        return True
    if not np.all(np.isfinite(v)):
        return False
    return float(np.max(np.abs(v))) < 2.0**52 / 10.0 ** (decimals + 1)


#: :func:`fixed_point_rows` styles per column (bits): no leading zero (``.5``), no trailing zeros (``1.2``), and with
#: trailing zeros dropped a whole number keeps its point (``10.``: Fanuc reads ``X10`` as 10 increments)
NO_LEADING_ZERO, NO_TRAILING_ZEROS, KEEP_POINT = 1, 2, 4


@numba.njit(cache=True)
def _put_fixed(out, pos, x, scale, decimals, style):  # pragma: no cover - numba
    k = np.rint(x * scale)  # np.round(x, d) is rint(x * 10^d) / 10^d: the same integer
    if k < 0:
        out[pos] = 45  # '-'
        pos += 1
        k = -k
    n = np.int64(k)
    ip = n // np.int64(scale)
    fp = n - ip * np.int64(scale)
    nd = decimals
    if style & NO_TRAILING_ZEROS:
        while nd > 0 and fp % 10 == 0:
            fp //= 10
            nd -= 1
        if n == 0:  # zero: "0"
            out[pos] = 48
            return pos + 1
    if not (ip == 0 and nd > 0 and style & NO_LEADING_ZERO):
        pos = _put_int(out, pos, ip)  # integer part (ip >= 0: the sign is written above)
    if nd > 0 or (decimals > 0 and not style & NO_TRAILING_ZEROS) or (decimals > 0 and style & KEEP_POINT):
        out[pos] = 46  # '.'
        pos += 1
    for q in range(nd - 1, -1, -1):
        out[pos + q] = 48 + fp % 10
        fp //= 10
    pos += nd
    return pos


@numba.njit(cache=True)
def fixed_point_rows(values, present, decimals, letters, sep, out, styles):  # pragma: no cover - numba
    """Rows of fixed-point numbers into ``out``; returns the bytes written.

    Parameters
    ----------
    values : (m, k) float64
    present : (m, k) bool
        Which numbers each row holds (a row with none writes nothing, not even its newline).
    decimals : (k,) int64
        Digits after the point per column (0..9).
    letters : (k,) uint8
        Address letter written before each number (0: none).
    sep : uint8
        Byte between two numbers of a row (a space; 0: none, ``G3X1.2Y3.4``).
    out : (>= m * (k * FIXED_MAX_CHARS + 1),) uint8
    styles : (k,) int64
        Per column, bits of :data:`NO_LEADING_ZERO`, :data:`NO_TRAILING_ZEROS`, :data:`KEEP_POINT` (0: ``%.{d}f``).
    """
    m, k = values.shape
    scales = np.empty(k)
    for c in range(k):
        scales[c] = 10.0 ** decimals[c]
    pos = 0
    for r in range(m):
        first = True
        for c in range(k):
            if not present[r, c]:
                continue
            if not first and sep != 0:
                out[pos] = sep
                pos += 1
            first = False
            if letters[c] != 0:
                out[pos] = letters[c]
                pos += 1
            pos = _put_fixed(out, pos, values[r, c], scales[c], decimals[c], styles[c])
        if not first:
            out[pos] = 10
            pos += 1
    return pos


@intrinsic
def _strfromd_17g(typingctx, buf, pos, value):  # pragma: no cover - compiled
    """``strfromd(buf + pos, 32, "%.17g", value)``: the C library's correctly rounded %.17g; bytes written."""
    sig = types.intp(buf, pos, value)

    def codegen(context, builder, signature, args):
        arr = context.make_array(signature.args[0])(context, builder, args[0])
        i8p = ir.IntType(8).as_pointer()
        ptr = builder.bitcast(builder.gep(arr.data, [args[1]]), i8p)
        fnty = ir.FunctionType(ir.IntType(32), [i8p, ir.IntType(64), i8p, ir.DoubleType()])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "strfromd")
        fmt = context.insert_const_string(builder.module, "%.17g")
        n = builder.call(fn, [ptr, ir.Constant(ir.IntType(64), 32), fmt, args[2]])
        return builder.sext(n, ir.IntType(64))

    return sig, codegen


@numba.njit(cache=True)
def _put_int(out, pos, n):  # pragma: no cover - numba
    if n < 0:
        out[pos] = 45
        pos += 1
        n = -n
    start = pos
    if n == 0:
        out[pos] = 48
        pos += 1
    while n > 0:
        out[pos] = 48 + n % 10
        n //= 10
        pos += 1
    i, j = start, pos - 1
    while i < j:
        out[i], out[j] = out[j], out[i]
        i += 1
        j -= 1
    return pos


def _powers_of_ten() -> tuple[np.ndarray, np.ndarray]:
    """10^k, k = -300..300, as double-double pairs (hi + lo, ~106 bits), from exact integers."""
    from fractions import Fraction

    hi, lo = np.empty(601), np.empty(601)
    for i, k in enumerate(range(-300, 301)):
        exact = Fraction(10) ** k
        hi[i] = float(exact)  # correctly rounded
        lo[i] = float(exact - Fraction(hi[i]))
    return hi, lo


_P10_HI, _P10_LO = _powers_of_ten()


@numba.njit(cache=True)
def _two_prod(a, b):  # pragma: no cover - numba
    """a * b = p + e exactly (Dekker's product; no fused multiply-add needed)."""
    p = a * b
    c = 134217729.0 * a
    ah = c - (c - a)
    al = a - ah
    c = 134217729.0 * b
    bh = c - (c - b)
    bl = b - bh
    e = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, e


@numba.njit(cache=True)
def _digits17(ax, e10, p_hi, p_lo):  # pragma: no cover - numba
    """(D, e10, ok): ax = D x 10^(e10 - 16) rounded to 17 digits, D in [10^16, 10^17); ok False: too near a tie."""
    for _ in range(4):
        k = 16 - e10 + 300
        s, err = _two_prod(ax, p_hi[k])
        t = err + ax * p_lo[k]
        yh = s + t
        yl = t - (yh - s)
        fh = np.floor(yh)
        r = (yh - fh) + yl
        fr = np.floor(r)
        d = np.int64(fh) + np.int64(fr)
        frac = r - fr
        if d >= 100000000000000000:
            e10 += 1
            continue
        if d < 10000000000000000:
            e10 -= 1
            continue
        if abs(frac - 0.5) < 1e-6:  # the double-double product cannot tell: the C library decides
            return d, e10, False
        if frac > 0.5:
            d += 1
        if d == 100000000000000000:
            d = 10000000000000000
            e10 += 1
        return d, e10, True
    return 0, e10, False


@numba.njit(cache=True)
def _put_g17(out, pos, x, dig, p_hi, p_lo):  # pragma: no cover - numba
    """``"%.17g" % x`` into out at pos; returns the new position.

    Correctly rounded 17 significant digits from a double-double product
    (|x| in [1e-280, 1e280]); near a rounding tie, and outside that range, the C
    library's strfromd. Then C's %g layout: fixed point when -4 <= exponent < 17,
    else d.ddde+XX; trailing zeros (and a bare point) removed.
    """
    ax = abs(x)
    if not (ax >= 1e-280 and ax <= 1e280):
        if x != x:
            out[pos] = 110
            out[pos + 1] = 97
            out[pos + 2] = 110
            return pos + 3
        return pos + _strfromd_17g(out, pos, x)
    d, e10, ok = _digits17(ax, np.int64(np.floor(np.log10(ax))), p_hi, p_lo)
    if not ok:
        return pos + _strfromd_17g(out, pos, x)
    for i in range(16, -1, -1):
        dig[i] = 48 + d % 10
        d //= 10
    last = 16  # the last nonzero digit
    while last > 0 and dig[last] == 48:
        last -= 1
    if x < 0:
        out[pos] = 45
        pos += 1
    if -4 <= e10 < 17:
        if e10 >= 0:
            for i in range(e10 + 1):
                out[pos] = dig[i]
                pos += 1
            if last > e10:
                out[pos] = 46
                pos += 1
                for i in range(e10 + 1, last + 1):
                    out[pos] = dig[i]
                    pos += 1
        else:
            out[pos] = 48
            out[pos + 1] = 46
            pos += 2
            for i in range(-e10 - 1):
                out[pos] = 48
                pos += 1
            for i in range(last + 1):
                out[pos] = dig[i]
                pos += 1
    else:
        out[pos] = dig[0]
        pos += 1
        if last > 0:
            out[pos] = 46
            pos += 1
            for i in range(1, last + 1):
                out[pos] = dig[i]
                pos += 1
        out[pos] = 101  # e
        out[pos + 1] = 45 if e10 < 0 else 43
        pos += 2
        ex = abs(e10)
        if ex >= 100:
            out[pos] = 48 + ex // 100
            pos += 1
        out[pos] = 48 + (ex // 10) % 10
        out[pos + 1] = 48 + ex % 10
        pos += 2
    return pos


@numba.njit(cache=True)
def csv_rows(ints, floats, out, p_hi, p_lo):  # pragma: no cover - numba
    """CSV rows ``%d,...,%.17g,...`` into ``out``; returns the bytes written.

    ``ints`` (m, a) int64, then ``floats`` (m, b) float64 per row (NaN as ``nan``,
    like Python); ``out`` holds at least ``m * (21 a + 26 b + 1)`` bytes;
    ``p_hi, p_lo``: the powers of ten (``_P10_HI``, ``_P10_LO``).
    """
    m, a = ints.shape
    b = floats.shape[1]
    dig = np.empty(20, np.uint8)
    pos = 0
    for r in range(m):
        for c in range(a):
            if c > 0:
                out[pos] = 44
                pos += 1
            pos = _put_int(out, pos, ints[r, c])
        for c in range(b):
            if a + c > 0:
                out[pos] = 44
                pos += 1
            x = floats[r, c]
            if x == 0.0:
                if np.signbit(x):
                    out[pos] = 45
                    pos += 1
                out[pos] = 48
                pos += 1
            else:
                pos = _put_g17(out, pos, x, dig, p_hi, p_lo)
        out[pos] = 10
        pos += 1
    return pos


# --------------------------------------------------------------------------------------
# Python entry points: one chunk of rows -> bytes (with Python's % where the kernels cannot be exact)
# --------------------------------------------------------------------------------------


def fixed_text(x: float, d: int, style: int = 0) -> str:
    """One number as :func:`fixed_point_rows` writes it (Python's ``%``; any size)."""
    s = f"{float(np.round(float(x), d)) + 0.0:.{d}f}"
    s = s[1:] if s.startswith("-") and float(s) == 0.0 else s
    if style & NO_TRAILING_ZEROS and d > 0:
        s = s.rstrip("0")
        if s.endswith(".") and not style & KEEP_POINT:
            s = s[:-1]
        if s in ("", ".", "-", "-.", "0.", "-0", "-0."):
            s = "0"
    if style & NO_LEADING_ZERO and s != "0":
        if s.startswith("0.") and len(s) > 2:
            s = s[1:]
        elif s.startswith("-0.") and len(s) > 3:
            s = "-" + s[2:]
    return s


def format_fixed(values: np.ndarray, decimals, *, letters: str | None = None, present: np.ndarray | None = None,
                 sep: str = " ", styles=0) -> bytes:
    """Rows of fixed-point numbers as bytes, one line per row (see :func:`fixed_point_rows`).

    Parameters
    ----------
    values : (m, k) float
    decimals : int or (k,) int
        Digits after the point (per column).
    letters : str of length k, optional
        Address letter before each column's number ("XYZF"); a space in it: none.
    present : (m, k) bool, optional
        Which numbers each row holds (default: all); a row with none is left out.
    sep : str
        One character between the numbers of a row, or "" (none).
    styles : int or (k,) int
        Per column, bits of :data:`NO_LEADING_ZERO`, :data:`NO_TRAILING_ZEROS`, :data:`KEEP_POINT`.
    """
    # writable (a copy of a read-only chunk): one compiled signature of fixed_point_rows, not two
    v = np.require(values, np.float64, ("C", "W"))
    m, k = v.shape
    dec = np.broadcast_to(np.asarray(decimals, dtype=np.int64), (k,)).copy()
    let = np.zeros(k, np.uint8) if letters is None else np.frombuffer(letters.replace(" ", "\0").encode(), np.uint8).copy()
    pres = np.ones((m, k), bool) if present is None else np.ascontiguousarray(present, dtype=bool)
    sty = np.broadcast_to(np.asarray(styles, dtype=np.int64), (k,)).copy()
    if len(sep) > 1:
        raise ValueError(f"sep must be one character or empty, got {sep!r}")
    if m == 0:
        return b""
    if all(fixed_point_exact(v[:, c], int(dec[c])) for c in range(k)):
        out = np.empty(m * (k * FIXED_MAX_CHARS + 1), np.uint8)
        n = fixed_point_rows(v, pres, dec, let, np.uint8(ord(sep) if sep else 0), out, sty)
        return out[:n].tobytes()
    lines = []
    for r in range(m):  # huge or non-finite numbers: Python's formatting, row by row
        words = [(chr(let[c]) if let[c] else "") + fixed_text(v[r, c], int(dec[c]), int(sty[c])) for c in range(k)
                 if pres[r, c]]
        if words:
            lines.append(sep.join(words) + "\n")
    return "".join(lines).encode("ascii")


def format_csv(ints: np.ndarray, floats: np.ndarray) -> bytes:
    """CSV rows of ``%d`` columns then ``%.17g`` columns, as bytes (see :func:`csv_rows`)."""
    iv = np.require(ints, np.int64, ("C", "W"))
    fv = np.require(floats, np.float64, ("C", "W"))
    m = len(iv)
    if m == 0:
        return b""
    if HAVE_STRFROMD:
        out = np.empty(m * (21 * iv.shape[1] + CSV_FLOAT_MAX_CHARS * fv.shape[1] + 1), np.uint8)
        n = csv_rows(iv, fv, out, _P10_HI, _P10_LO)
        return out[:n].tobytes()
    fmt = ",".join(["%d"] * iv.shape[1] + ["%.17g"] * fv.shape[1]) + "\n"
    return ((fmt * m) % tuple(np.column_stack([iv.astype(object), fv.astype(object)]).ravel().tolist())).encode()
