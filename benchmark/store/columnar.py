"""cells.csv rows written in bulk from arrays, by compiled code.

A reference map solves its cells as arrays (:meth:`ReferenceAdapter.solve_grid
<rockbench.engines.adapters.reference.ReferenceAdapter.solve_grid>`); formatting them one Python
object at a time would cost more than solving them (a float's ``repr`` alone takes about 1 µs, five
of them per row). :func:`format_rows` writes whole chunks of rows into one byte buffer instead, in
parallel, with the same text the per-cell path writes (:meth:`RunStore.append_results
<rockbench.benchmark.store.run_folder.RunStore.append_results>`): every float as Python's ``repr`` writes it,
the shortest decimal that reads back to the same double (Ryu: Ulf Adams, "Ryū: fast float-to-string
conversion", PLDI 2018, the ``d2d`` step of the reference implementation), laid out by
``repr``'s rule (positional for decimal exponents −4 ≤ e < 16, else ``d.ddde±XX``). The tests
compare it with ``repr`` on millions of doubles and the rows with the per-cell path's, byte for byte.
Chunks of fewer than :data:`COMPILED_MIN_ROWS` rows are formatted by ``repr`` itself (the same text;
the compiled writer would cost more to compile on a fresh install than it saves there).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from rockbench.benchmark.store.lines import plain_row

# every constant of the unsigned arithmetic is a uint64: numba would turn uint64 ⊕ int64 into float64
_U0, _U1, _U2, _U4, _U5, _U10, _U100 = (np.uint64(v) for v in (0, 1, 2, 4, 5, 10, 100))
_U32, _U52, _U64 = np.uint64(32), np.uint64(52), np.uint64(64)
_M32 = np.uint64(0xFFFFFFFF)
_M52 = np.uint64((1 << 52) - 1)

#: bits of the 128-bit multipliers (Ryu's DOUBLE_POW5_INV_BITCOUNT and DOUBLE_POW5_BITCOUNT)
_POW5_INV_BITS = 125
_POW5_BITS = 125


def _tables() -> tuple[np.ndarray, np.ndarray]:
    """Ryu's multipliers: ⌊2^j/5^q⌋ + 1 with j = bitlength(5^q) − 1 + 125, and the top 125 bits of
    5^i, each split into (low, high) 64-bit words."""
    inv = np.zeros((342, 2), np.uint64)
    pos = np.zeros((326, 2), np.uint64)
    mask = (1 << 64) - 1
    for q in range(inv.shape[0]):
        p5 = 5 ** q
        v = (1 << (p5.bit_length() - 1 + _POW5_INV_BITS)) // p5 + 1
        inv[q] = (v & mask, v >> 64)
    for i in range(pos.shape[0]):
        p5 = 5 ** i
        n = p5.bit_length()
        v = p5 >> (n - _POW5_BITS) if n > _POW5_BITS else p5 << (_POW5_BITS - n)
        pos[i] = (v & mask, v >> 64)
    return inv, pos


_POW5_INV, _POW5 = _tables()


@njit(cache=True)
def _mul_shift64(m, lo, hi, j):
    """⌊m·(hi·2⁶⁴ + lo) / 2^j⌋ for 64 < j < 128 (m below 2⁵⁵)."""
    # m·lo and m·hi as 128-bit products from 32-bit halves
    a_lo, a_hi = m & _M32, m >> _U32
    # m·hi
    b_lo, b_hi = hi & _M32, hi >> _U32
    p00, p01, p10, p11 = a_lo * b_lo, a_lo * b_hi, a_hi * b_lo, a_hi * b_hi
    mid1 = p10 + (p00 >> _U32)
    mid2 = p01 + (mid1 & _M32)
    hi1 = p11 + (mid1 >> _U32) + (mid2 >> _U32)
    lo1 = (mid2 << _U32) | (p00 & _M32)
    # the high word of m·lo
    b_lo, b_hi = lo & _M32, lo >> _U32
    p00, p01, p10, p11 = a_lo * b_lo, a_lo * b_hi, a_hi * b_lo, a_hi * b_hi
    mid1 = p10 + (p00 >> _U32)
    mid2 = p01 + (mid1 & _M32)
    hi0 = p11 + (mid1 >> _U32) + (mid2 >> _U32)
    s = hi0 + lo1
    if s < hi0:
        hi1 += _U1
    d = np.uint64(j - 64)
    return (hi1 << (_U64 - d)) | (s >> d)


@njit(cache=True)
def _pow5_factor(v):
    n = 0
    while v != _U0 and v % _U5 == _U0:
        v //= _U5
        n += 1
    return n


@njit(cache=True)
def _shortest(bits):
    """The shortest decimal ``digits·10^exp`` that reads back to the finite, non-zero double of
    IEEE bits ``bits`` (sign ignored); the closest such one, ties to even (Ryu's d2d).

    Long (89 lines) on purpose: it is Ryu's d2d step for step, one numba kernel called per float, so
    that the columnar writer's text equals Python's ``repr`` byte for byte (tests/test_columnar.py);
    split into helpers it would be harder to check against the algorithm and slower to compile.
    """
    ieee_m = bits & _M52
    ieee_e = np.int64((bits >> _U52) & np.uint64(0x7FF))
    if ieee_e == 0:
        e2 = 1 - 1023 - 52 - 2
        m2 = ieee_m
    else:
        e2 = ieee_e - 1023 - 52 - 2
        m2 = (_U1 << _U52) | ieee_m
    accept = (m2 & _U1) == _U0
    mv = _U4 * m2
    mm_shift = _U1 if (ieee_m != _U0 or ieee_e <= 1) else _U0
    vm_tz = False
    vr_tz = False
    if e2 >= 0:
        q = ((e2 * 78913) >> 18) - (1 if e2 > 3 else 0)
        e10 = q
        k = _POW5_INV_BITS + (((q * 1217359) >> 19) + 1) - 1
        i = -e2 + q + k
        lo, hi = _POW5_INV[q, 0], _POW5_INV[q, 1]
        vr = _mul_shift64(mv, lo, hi, i)
        vp = _mul_shift64(mv + _U2, lo, hi, i)
        vm = _mul_shift64(mv - _U1 - mm_shift, lo, hi, i)
        if q <= 21:
            if mv % _U5 == _U0:
                vr_tz = _pow5_factor(mv) >= q
            elif accept:
                vm_tz = _pow5_factor(mv - _U1 - mm_shift) >= q
            elif _pow5_factor(mv + _U2) >= q:
                vp -= _U1
    else:
        q = ((-e2 * 732923) >> 20) - (1 if -e2 > 1 else 0)
        e10 = q + e2
        i = -e2 - q
        k = (((i * 1217359) >> 19) + 1) - _POW5_BITS
        j = q - k
        lo, hi = _POW5[i, 0], _POW5[i, 1]
        vr = _mul_shift64(mv, lo, hi, j)
        vp = _mul_shift64(mv + _U2, lo, hi, j)
        vm = _mul_shift64(mv - _U1 - mm_shift, lo, hi, j)
        if q <= 1:
            vr_tz = True
            if accept:
                vm_tz = mm_shift == _U1
            else:
                vp -= _U1
        elif q < 63:
            vr_tz = (mv & ((_U1 << np.uint64(q)) - _U1)) == _U0
    removed = 0
    last = _U0
    if vm_tz or vr_tz:
        while vp // _U10 > vm // _U10:
            vm_tz = vm_tz and vm % _U10 == _U0
            vr_tz = vr_tz and last == _U0
            last = vr % _U10
            vr //= _U10
            vp //= _U10
            vm //= _U10
            removed += 1
        if vm_tz:
            while vm % _U10 == _U0:
                vr_tz = vr_tz and last == _U0
                last = vr % _U10
                vr //= _U10
                vp //= _U10
                vm //= _U10
                removed += 1
        if vr_tz and last == _U5 and vr % _U2 == _U0:
            last = np.uint64(4)   # exactly …50…0: round to even
        up = (vr == vm and (not accept or not vm_tz)) or last >= _U5
        out = vr + (_U1 if up else _U0)
    else:
        up = False
        if vp // _U100 > vm // _U100:
            up = vr % _U100 >= np.uint64(50)
            vr //= _U100
            vp //= _U100
            vm //= _U100
            removed += 2
        while vp // _U10 > vm // _U10:
            up = vr % _U10 >= _U5
            vr //= _U10
            vp //= _U10
            vm //= _U10
            removed += 1
        out = vr + (_U1 if (vr == vm or up) else _U0)
    return out, e10 + removed


@njit(cache=True)
def _n_digits(v):
    n = 1
    while v >= _U10:
        v //= _U10
        n += 1
    return n


@njit(cache=True)
def _repr_float(bits, buf, pos, write):
    """Python's ``repr`` of the double with IEEE bits ``bits``: written into ``buf`` at ``pos``
    when ``write``; returns the position after it (its length when ``pos`` is 0 and not written)."""
    neg = (bits >> np.uint64(63)) != _U0
    e = (bits >> _U52) & np.uint64(0x7FF)
    m = bits & _M52
    if e == np.uint64(0x7FF) and m != _U0:   # nan (repr drops its sign)
        if write:
            buf[pos], buf[pos + 1], buf[pos + 2] = 110, 97, 110
        return pos + 3
    if neg:
        if write:
            buf[pos] = 45
        pos += 1
    if e == np.uint64(0x7FF):                  # ±inf
        if write:
            buf[pos], buf[pos + 1], buf[pos + 2] = 105, 110, 102
        return pos + 3
    if e == _U0 and m == _U0:
        if write:
            buf[pos], buf[pos + 1], buf[pos + 2] = 48, 46, 48   # 0.0
        return pos + 3
    digits, exp = _shortest(bits)
    nd = _n_digits(digits)
    decpt = nd + exp                      # the decimal point sits after this many digits
    if decpt <= -4 or decpt > 16:
        # d.ddde±XX
        x = decpt - 1
        ax = -x if x < 0 else x
        ne = 2 if ax < 100 else 3
        n = nd + (1 if nd > 1 else 0) + 2 + ne
        if write:
            v = digits
            for k in range(nd - 1, -1, -1):
                d = np.int64(v % _U10)
                v //= _U10
                buf[pos + (k + 1 if k > 0 else 0)] = 48 + d
            if nd > 1:
                buf[pos + 1] = 46
            p = pos + nd + (1 if nd > 1 else 0)
            buf[p] = 101
            buf[p + 1] = 45 if x < 0 else 43
            for k in range(ne - 1, -1, -1):
                buf[p + 2 + k] = 48 + ax % 10
                ax //= 10
        return pos + n
    if decpt <= 0:
        # 0.000ddd
        n = 2 - decpt + nd
        if write:
            buf[pos], buf[pos + 1] = 48, 46
            for k in range(-decpt):
                buf[pos + 2 + k] = 48
            v = digits
            for k in range(nd - 1, -1, -1):
                buf[pos + 2 - decpt + k] = 48 + np.int64(v % _U10)
                v //= _U10
        return pos + n
    if decpt < nd:
        # ddd.ddd
        n = nd + 1
        if write:
            v = digits
            for k in range(nd - 1, -1, -1):
                buf[pos + (k + 1 if k >= decpt else k)] = 48 + np.int64(v % _U10)
                v //= _U10
            buf[pos + decpt] = 46
        return pos + n
    # ddd000.0
    n = decpt + 2
    if write:
        v = digits
        for k in range(nd - 1, -1, -1):
            buf[pos + k] = 48 + np.int64(v % _U10)
            v //= _U10
        for k in range(nd, decpt):
            buf[pos + k] = 48
        buf[pos + decpt] = 46
        buf[pos + decpt + 1] = 48
    return pos + n


@njit(cache=True)
def _int_len(v):
    n = 1 if v >= 0 else 2
    a = -v if v < 0 else v
    while a >= 10:
        a //= 10
        n += 1
    return n


@njit(cache=True)
def _put_int(buf, pos, v):
    n = _int_len(v)
    a = v
    if v < 0:
        buf[pos] = 45
        a = -v
    for k in range(n - 1, 0 if v < 0 else -1, -1):
        buf[pos + k] = 48 + a % 10
        a //= 10
    return pos + n


@njit(cache=True)
def _put_bytes(buf, pos, src, lo, hi):
    for k in range(lo, hi):
        buf[pos + k - lo] = src[k]
    return pos + hi - lo


@njit(cache=True)
def _floats_len(bits, starts):
    out = np.empty(bits.size, np.int64)
    for k in prange(bits.size):
        out[k] = _repr_float(bits[k], starts, 0, False) + 1   # the text and its newline
    return out


@njit(cache=True)
def _floats_put(bits, offsets, buf):
    for k in prange(bits.size):
        p = _repr_float(bits[k], buf, offsets[k], True)
        buf[p] = 10


def repr_floats(values) -> list[str]:
    """``[repr(float(x)) for x in values]``, computed by the compiled writer (for tests and checks)."""
    bits = np.ascontiguousarray(values, dtype=np.float64).view(np.uint64).ravel()
    if bits.size == 0:
        return []
    lens = _floats_len(bits, np.empty(1, np.uint8))
    off = np.zeros(bits.size, np.int64)
    np.cumsum(lens[:-1], out=off[1:])
    buf = np.empty(int(off[-1] + lens[-1]), np.uint8)
    _floats_put(bits, off, buf)
    return buf.tobytes().decode("ascii").split("\n")[:-1]


# -- rows of cells.csv ---------------------------------------------------------------------------
#: which float columns a row writes: always, only where the flag column says so, or '' where NaN
_ALWAYS, _IF_OVERTURN, _EMPTY_IF_NAN = 0, 1, 2


@njit(cache=True)
def _row(k, write, buf, pos, head, ax_txt, ax_off, ii, jj, outcome, words, word_off, n_imp, fl_bits, theta,
         t_over, t_up, n_min, f_max):
    """One row of cells.csv (results.COLUMNS) for cell ``k`` of the chunk; see :func:`format_rows`."""
    i, j = ii[k], jj[k]
    pos = _put_bytes(buf, pos, head, 0, head.size) if write else pos + head.size
    # w_ratio, a_ratio, omega, amplitude: texts of the axes, by column j and row i
    for which, idx in ((0, j), (1, i), (2, j), (3, i)):
        lo, hi = ax_off[which, idx], ax_off[which, idx + 1]
        pos = _put_bytes(buf, pos, ax_txt, lo, hi) if write else pos + hi - lo
        if write:
            buf[pos] = 44
        pos += 1
    # outcome word, n_impacts, max |θ|
    o = outcome[k]
    lo, hi = word_off[o], word_off[o + 1]
    pos = _put_bytes(buf, pos, words, lo, hi) if write else pos + hi - lo
    if write:
        buf[pos] = 44
    pos += 1
    pos = _put_int(buf, pos, n_imp[k]) if write else pos + _int_len(n_imp[k])
    if write:
        buf[pos] = 44
    pos += 1
    pos = _repr_float(theta[k], buf, pos, write)
    if write:
        buf[pos] = 44
    pos += 1
    # valid, flags, status, message, wall_s: words 3.. of the table (see format_rows)
    fb = fl_bits[k]
    w = 3 + (0 if fb == 0 else 1)              # true / false
    lo, hi = word_off[w], word_off[w + 1]
    pos = _put_bytes(buf, pos, words, lo, hi) if write else pos + hi - lo
    if write:
        buf[pos] = 44
    pos += 1
    w = 6 + fb                                 # the flags' text
    lo, hi = word_off[w], word_off[w + 1]
    pos = _put_bytes(buf, pos, words, lo, hi) if write else pos + hi - lo
    lo, hi = word_off[5], word_off[6]          # ",ok,,<wall_s>,,,": wall_s, then the empty cost
    pos = _put_bytes(buf, pos, words, lo, hi) if write else pos + hi - lo
    # t_overturn (overturned cells), t_uplift ('' where never lifted), min N, max |F|/N
    if o == 2:
        pos = _repr_float(t_over[k], buf, pos, write)
    if write:
        buf[pos] = 44
    pos += 1
    b = t_up[k]
    if not ((b >> _U52) & np.uint64(0x7FF) == np.uint64(0x7FF) and b & _M52 != _U0):
        pos = _repr_float(b, buf, pos, write)
    if write:
        buf[pos] = 44
    pos += 1
    pos = _repr_float(n_min[k], buf, pos, write)
    if write:
        buf[pos] = 44
    pos += 1
    pos = _repr_float(f_max[k], buf, pos, write)
    if write:
        buf[pos] = 44
    pos += 1
    pos = _put_int(buf, pos, i) if write else pos + _int_len(i)
    if write:
        buf[pos] = 44
    pos += 1
    pos = _put_int(buf, pos, j) if write else pos + _int_len(j)
    if write:
        buf[pos] = 10
    return pos + 1


@njit(parallel=True, cache=True)
def _rows(head, ax_txt, ax_off, ii, jj, outcome, words, word_off, n_imp, fl_bits, theta, t_over, t_up, n_min,
          f_max):
    n = ii.size
    lens = np.empty(n, np.int64)
    dummy = np.empty(1, np.uint8)
    for k in prange(n):
        lens[k] = _row(k, False, dummy, 0, head, ax_txt, ax_off, ii, jj, outcome, words, word_off, n_imp, fl_bits,
                       theta, t_over, t_up, n_min, f_max)
    off = np.empty(n + 1, np.int64)
    off[0] = 0
    for k in range(n):
        off[k + 1] = off[k] + lens[k]
    buf = np.empty(off[n], np.uint8)
    for k in prange(n):
        _row(k, True, buf, off[k], head, ax_txt, ax_off, ii, jj, outcome, words, word_off, n_imp, fl_bits, theta,
             t_over, t_up, n_min, f_max)
    return buf


def _texts(strings: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Strings as one byte array and the offsets of each (``n + 1`` of them)."""
    raw = [s.encode("utf-8") for s in strings]
    off = np.zeros(len(raw) + 1, np.int64)
    np.cumsum([len(r) for r in raw], out=off[1:])
    return np.frombuffer(b"".join(raw), np.uint8).copy() if raw else np.zeros(0, np.uint8), off


#: Chunks of fewer rows are formatted by Python's own ``repr`` (:func:`_format_rows_py`, the same
#: text): a few milliseconds for the default suite's 51 × 51 maps, where the compiled writer's first
#: compile on a fresh install costs about 9 s of one core.
COMPILED_MIN_ROWS = 10_000

_OUTCOME_WORDS = ("rest", "rocking", "overturn")


def _format_rows_py(head, axes, ii, jj, outcome, n_impacts, flag_bits, flag_texts, theta, t_over, t_up, n_min,
                    f_max, wall_s: str) -> bytes:
    """:func:`format_rows` by Python's ``repr``: the per-cell path's line (:func:`~.store.plain_row`)."""
    wr, ar, om, am = axes
    cols = [np.asarray(a).tolist() for a in (ii, jj, outcome, n_impacts, flag_bits)]
    flts = [np.asarray(a, dtype=np.float64).tolist() for a in (theta, t_over, t_up, n_min, f_max)]
    return "".join(
        plain_row(head, wr[j], ar[i], om[j], am[i], i, j, _OUTCOME_WORDS[o], n, th, b == 0, flag_texts[b], wall_s,
                  tov if o == 2 else None, None if tup != tup else tup, nmin, fmax)
        for i, j, o, n, b, th, tov, tup, nmin, fmax in zip(*cols, *flts)).encode("utf-8")


def format_rows(head: str, axes: list[list[str]], ii, jj, outcome, n_impacts, flag_bits, flag_texts: list[str],
                max_abs_theta_rad, t_overturn_s, t_uplift_s, min_normal_mg, max_friction_ratio,
                wall_s: str) -> bytes:
    """The cells.csv rows of successful cells, one per entry of ``ii``/``jj``, as bytes.

    Parameters
    ----------
    head : str
        The first five fields and their commas (``engine,block,pulse,restitution,eta,``), quoted
        as the csv module would.
    axes : list of 4 lists of str
        The texts of ``w_ratio`` and ``omega_rad_s`` by column, ``a_ratio`` and ``amplitude_mps2``
        by row (as ``repr`` writes them).
    ii, jj : ndarray of int
        Row (amplitude) and column (frequency) of each cell.
    outcome : ndarray of int
        Outcome codes (0 rest, 1 rocking, 2 overturn).
    n_impacts : ndarray of int
        Impacts [-].
    flag_bits : ndarray of int
        The flags as bits (0: valid), an index into ``flag_texts``.
    flag_texts : list of str
        The flags column for each value of ``flag_bits``.
    max_abs_theta_rad, t_overturn_s, t_uplift_s, min_normal_mg, max_friction_ratio : ndarray of float
        The float columns; ``t_overturn_s`` is written for overturned cells only, ``t_uplift_s``
        empty where NaN.
    wall_s : str
        The ``wall_s`` field, one for the chunk.
    """
    n = len(ii)
    if n == 0:
        return b""
    oc = np.ascontiguousarray(outcome, np.int64)
    if oc.size and (oc.min() < 0 or oc.max() > 2):
        raise ValueError("format_rows writes successful cells only (outcome codes 0, 1, 2)")
    fb = np.ascontiguousarray(flag_bits, np.int64)
    if fb.size and (fb.min() < 0 or fb.max() >= len(flag_texts)):
        raise ValueError(f"flag bits beyond the {len(flag_texts)} flag texts given")
    if n < COMPILED_MIN_ROWS:
        return _format_rows_py(head, axes, ii, jj, oc, n_impacts, fb, flag_texts, max_abs_theta_rad, t_overturn_s,
                               t_uplift_s, min_normal_mg, max_friction_ratio, wall_s)
    ax_txt, ax_off = [], []
    for a in axes:
        t, o = _texts(a)
        ax_txt.append(t)
        ax_off.append(o)
    width = max(o.size for o in ax_off)
    off = np.zeros((4, width), np.int64)
    base = 0
    for k, o in enumerate(ax_off):
        off[k, :o.size] = o + base
        base += int(o[-1])
    # the status, message, wall_s and the empty cost columns (cpu_s, simulated_s): the same text in every row
    words, word_off = _texts(["rest", "rocking", "overturn", "true", "false", f",ok,,{wall_s},,,", *flag_texts])

    def u64(a):
        return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)

    buf = _rows(np.frombuffer(head.encode("utf-8"), np.uint8).copy(), np.concatenate(ax_txt), off,
                np.ascontiguousarray(ii, np.int64), np.ascontiguousarray(jj, np.int64),
                oc, words, word_off, np.ascontiguousarray(n_impacts, np.int64),
                fb, u64(max_abs_theta_rad), u64(t_overturn_s),
                u64(t_uplift_s), u64(min_normal_mg), u64(max_friction_ratio))
    return buf.tobytes()
