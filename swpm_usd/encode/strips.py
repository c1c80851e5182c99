"""Winding-preserving triangle stripifier and strip decoder (for skip strips, Forsyth 4.1 / El-Sana 1999).

A strip ``s`` draws triangle ``i`` (counted from the start of its strip) as ``(s[i], s[i+1], s[i+2])`` when
``i`` is even and ``(s[i+1], s[i], s[i+2])`` when ``i`` is odd (the OpenGL / Direct3D rule), so a strip
alternates the order of its indices while keeping every triangle's facing. :func:`stripify` keeps the
input order as far as possible (it is meant to follow a vertex-cache order): like meshoptimizer's stripifier
it looks for the next triangle only among the first ``window`` not yet emitted triangles of the input, and it
only continues a strip across its last edge when the neighbour's winding matches the strip's parity, so every
decoded triangle is an input triangle with its winding (possibly rotated). Strips are joined either by a
restart index (``restart_index``) or, when that is ``None``, by two repeated indices (degenerate joins; a new
strip's first triangle is emitted in the order its parity needs, so no extra parity index is spent).
"""

from __future__ import annotations

import numba as nb
import numpy as np

__all__ = ["decode_strip", "stripify"]


@nb.njit(cache=True)
def _edge_table(tris: np.ndarray, V: int):
    """Sorted directed-edge keys ``a * V + b`` of every triangle and the triangle of each key."""
    T = tris.shape[0]
    keys = np.empty(3 * T, np.int64)
    for t in range(T):
        for j in range(3):
            keys[3 * t + j] = tris[t, j] * V + tris[t, (j + 1) % 3]
    order = np.argsort(keys, kind="mergesort")
    return keys[order], order // 3


@nb.njit(cache=True)
def _has_open_neighbour(keys, key_tri, emitted, a: int, b: int, V: int) -> bool:
    """Is there a not yet emitted triangle with directed edge a -> b?"""
    key = a * V + b
    i = np.searchsorted(keys, key)
    while i < keys.shape[0] and keys[i] == key:
        if not emitted[key_tri[i]]:
            return True
        i += 1
    return False


@nb.njit(cache=True)
def _stripify(tris: np.ndarray, V: int, use_restart: bool, restart: int, window: int) -> np.ndarray:
    T = tris.shape[0]
    out = np.empty(5 * T + 2, np.int64)
    if T == 0:
        return out[:0]
    keys, key_tri = _edge_table(tris, V)
    emitted = np.zeros(T, np.bool_)
    valence = np.zeros(V, np.int64)
    for t in range(T):
        for j in range(3):
            valence[tris[t, j]] += 1
    buf = np.empty(window, np.int64)
    bsize = 0
    next_in = 0
    n = 0
    pos0 = 0  # first index of the current strip (parity origin)
    in_strip = False
    while True:
        while bsize < window and next_in < T:
            buf[bsize] = next_in
            bsize += 1
            next_in += 1
        if bsize == 0:
            break
        pick = -1
        third = -1
        if in_strip:
            a = out[n - 2]
            b = out[n - 1]
            if ((n - 2 - pos0) & 1) == 1:
                a, b = b, a  # odd triangle: decoded (b, a, c), needs directed edge b -> a
            for i in range(bsize):
                t = buf[i]
                for j in range(3):
                    if tris[t, j] == a and tris[t, (j + 1) % 3] == b:
                        pick = i
                        third = tris[t, (j + 2) % 3]
                        break
                if pick >= 0:
                    break
        if pick >= 0:
            t = buf[pick]
            out[n] = third
            n += 1
        else:
            # start a strip at the buffered triangle whose least-used vertex is least used (strip borders)
            best = 1 << 60
            for i in range(bsize):
                t = buf[i]
                m = min(valence[tris[t, 0]], min(valence[tris[t, 1]], valence[tris[t, 2]]))
                if m < best:
                    best = m
                    pick = i
            t = buf[pick]
            if in_strip:
                if use_restart:
                    out[n] = restart
                    n += 1
                else:
                    out[n] = out[n - 1]
                    n += 1
            # rotation (u, v, w): u is left behind, the strip continues across edge v-w; prefer a rotation
            # whose continuation has an open neighbour, then the least used u
            best_r = 0
            best_s = 1 << 62
            for r in range(3):
                u = tris[t, r]
                v = tris[t, (r + 1) % 3]
                w = tris[t, (r + 2) % 3]
                emitted[t] = True
                s = valence[u]
                if not _has_open_neighbour(keys, key_tri, emitted, w, v, V):
                    s += 1 << 40
                emitted[t] = False
                if s < best_s:
                    best_s = s
                    best_r = r
            u = tris[t, best_r]
            v = tris[t, (best_r + 1) % 3]
            w = tris[t, (best_r + 2) % 3]
            if in_strip and not use_restart:
                out[n] = u
                n += 1
            if in_strip and use_restart:
                pos0 = n
            elif not in_strip:
                pos0 = n
            out[n] = u
            if ((n - pos0) & 1) == 0:
                out[n + 1] = v
                out[n + 2] = w
            else:
                out[n + 1] = w
                out[n + 2] = v
            n += 3
            in_strip = True
        emitted[t] = True
        for j in range(3):
            valence[tris[t, j]] -= 1
        for i in range(pick, bsize - 1):
            buf[i] = buf[i + 1]
        bsize -= 1
    return out[:n].copy()


def stripify(
    triangles: np.ndarray, vertex_count: int, restart_index: int | None = 0xFFFFFFFF, window: int = 8
) -> np.ndarray:
    """Turn ``triangles`` (T, 3), in their preferred (vertex-cache) order, into one strip (int64).

    ``restart_index`` separates strips (``None``: join them with degenerate triangles instead). ``window``
    is how many of the next not yet emitted input triangles may continue a strip. Decoding the result with
    :func:`decode_strip` gives exactly the input triangles (as a multiset) with their winding.
    """
    tris = np.ascontiguousarray(np.asarray(triangles).reshape(-1, 3), dtype=np.int64)
    use_restart = restart_index is not None
    r = int(restart_index) if use_restart else -1
    if use_restart and tris.size and (tris.max() >= r or tris.min() < 0):
        raise ValueError("vertex indices must be non-negative and below the restart index")
    return _stripify(tris, int(vertex_count), use_restart, r, max(1, int(window)))


@nb.njit(cache=True)
def _decode(strip: np.ndarray, restart: int, has_restart: bool, keep_degenerate: bool) -> np.ndarray:
    out = np.empty((max(strip.shape[0] - 2, 0), 3), np.int64)
    n = 0
    run = 0
    a = -1
    b = -1
    for i in range(strip.shape[0]):
        c = strip[i]
        if has_restart and c == restart:
            run = 0
            continue
        if run >= 2 and (keep_degenerate or (a != b and b != c and a != c)):
            if ((run - 2) & 1) == 0:
                out[n, 0] = a
                out[n, 1] = b
            else:
                out[n, 0] = b
                out[n, 1] = a
            out[n, 2] = c
            n += 1
        a = b
        b = c
        run += 1
    return out[:n].copy()


def decode_strip(
    strip: np.ndarray, restart_index: int | None = None, keep_degenerate: bool = False
) -> np.ndarray:
    """The triangles a strip draws, (n, 3) int64 with their winding (odd triangles flipped back).

    Restart indices end a strip; degenerate triangles are skipped unless ``keep_degenerate``.
    """
    s = np.ascontiguousarray(np.asarray(strip).reshape(-1), dtype=np.int64)
    has = restart_index is not None
    return _decode(s, int(restart_index) if has else -1, has, bool(keep_degenerate))
