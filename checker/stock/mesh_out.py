"""The dexel stock as a closed triangle mesh written as binary STL (docs/MATH.md §14): the union
of the h x h columns around the rays, each interval [lo, hi] the box cell x [lo, hi]. Part
frame, mm.

Faces: a top quad where a column's material ends going up and a bottom quad where it starts
(touching intervals make none between them); on the vertical face between two neighbouring
columns (or a column and the grid's outside) a wall over the z where exactly one of them has
material, facing out of it. A vertical line at a corner of the grid is met by the faces of its
four columns, so every face along it is split at all of their interval ends (a wall between two
corners is the zipper triangulation of its two lines' points): no vertex lies inside another
face's edge and the surface is closed, every directed edge matched by its reverse. Where only
diagonal neighbours hold material the edge they share is used by four faces (the union's own
non-manifold edge). Built with numpy in bands of rows."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from checker.atomic import write_file
from checker.stock.dexels import Dexels

_HEADER = 84  # binary STL: 80 bytes of text, the triangle count as uint32
_BAND_COLUMNS = 25_000  # columns per band: bounds the walls' temporaries (~250 MB at most)


def _ends(d: Dexels) -> tuple[np.ndarray, np.ndarray]:
    """`lo, hi (ny + 2, nx + 2, capacity)` float64 with a ring of empty columns around; empty
    slots (beyond count, or of zero length) are +inf, holding nothing."""
    slot = np.arange(d.capacity)[None, None, :] < d.count[:, :, None]
    lo, hi = d.lo.astype(np.float64), d.hi.astype(np.float64)
    used = slot & (hi > lo)
    shape = (d.ny + 2, d.nx + 2, d.capacity)
    plo, phi = np.full(shape, np.inf), np.full(shape, np.inf)
    plo[1:-1, 1:-1] = np.where(used, lo, np.inf)
    phi[1:-1, 1:-1] = np.where(used, hi, np.inf)
    return plo, phi


def _above(lo: np.ndarray, hi: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Material just above z: (..., K) heights against (..., C) intervals -> (..., K) bool."""
    return ((lo[..., None, :] <= z[..., None]) & (z[..., None] < hi[..., None, :])).any(-1)


def _below(lo: np.ndarray, hi: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Material just below z."""
    return ((lo[..., None, :] < z[..., None]) & (z[..., None] <= hi[..., None, :])).any(-1)


def _unique_sorted(z: np.ndarray) -> np.ndarray:
    """Each row sorted with repeats replaced by +inf (at the end)."""
    z = np.sort(z, axis=-1)
    repeat = np.zeros(z.shape, bool)
    repeat[..., 1:] = z[..., 1:] == z[..., :-1]
    return np.sort(np.where(repeat, np.inf, z), axis=-1)


def _corner_points(plo: np.ndarray, phi: np.ndarray, j0: int, j1: int) -> np.ndarray:
    """`(j1 - j0 + 1, nx + 1, K)` the interval ends of the four columns around each corner of
    corner rows j0..j1, sorted, unique, +inf padded (K trimmed to the most any corner has)."""
    ends = np.concatenate([plo[j0:j1 + 2], phi[j0:j1 + 2]], axis=-1)  # padded rows j0 .. j1+1
    z = np.concatenate([ends[:-1, :-1], ends[:-1, 1:], ends[1:, :-1], ends[1:, 1:]], axis=-1)
    z = _unique_sorted(z)
    k = max(int(np.isfinite(z).sum(axis=-1).max(initial=0)), 1)
    return z[..., :k]


def _caps(plo, phi, X, Y, j0, j1) -> np.ndarray:
    """The top and bottom quads of columns rows j0..j1-1 as triangles (M, 3, 3)."""
    lo, hi = plo[j0 + 1:j1 + 1, 1:-1], phi[j0 + 1:j1 + 1, 1:-1]
    z = np.concatenate([lo, hi], axis=-1)
    finite = np.isfinite(z)
    up, down = _above(lo, hi, z), _below(lo, hi, z)
    out = []
    for face, sign in ((finite & up & ~down, -1.0), (finite & down & ~up, 1.0)):
        jj, ii, kk = np.nonzero(face)
        zz = z[jj, ii, kk]
        jj = jj + j0
        c = np.stack([np.column_stack([X[ii + a], Y[jj + b], zz])
                      for a, b in ((0, 0), (1, 0), (1, 1), (0, 1))], axis=1)  # (M, 4, 3) ccw
        order = [[0, 1, 2], [0, 2, 3]] if sign > 0 else [[0, 2, 1], [0, 3, 2]]
        out.append(c[:, order].reshape(-1, 3, 3))
    return np.concatenate(out)


def _walls(zp, zq, p_xy, q_xy, a_lo, a_hi, b_lo, b_hi, normal_axis) -> np.ndarray:
    """The zipper triangles of walls between the vertical lines at `p_xy, q_xy (W, 2)` with
    points `zp, zq (W, K)` where exactly one of columns a, b (`(W, C)` intervals; a on the low
    side along `normal_axis`) has material, each facing out of it: (M, 3, 3)."""
    w, k = zp.shape
    z = np.concatenate([zp, zq], axis=1)
    tag = np.concatenate([np.zeros((w, k), np.int8), np.ones((w, k), np.int8)], axis=1)
    order = np.argsort(z, axis=1, kind="stable")  # ties: the P point first
    z = np.take_along_axis(z, order, axis=1)
    tag = np.take_along_axis(tag, order, axis=1)
    pos = np.broadcast_to(np.arange(2 * k), (w, 2 * k))
    last_p = np.maximum.accumulate(np.where(tag == 0, pos, -1), axis=1)
    last_q = np.maximum.accumulate(np.where(tag == 1, pos, -1), axis=1)
    prev_p = np.concatenate([np.full((w, 1), -1), last_p[:, :-1]], axis=1)
    prev_q = np.concatenate([np.full((w, 1), -1), last_q[:, :-1]], axis=1)
    ok = np.isfinite(z) & (prev_p >= 0) & (prev_q >= 0)
    rows, t = np.nonzero(ok)
    pp, qq = prev_p[rows, t], prev_q[rows, t]
    zv, zpp, zqq = z[rows, t], z[rows, pp], z[rows, qq]
    z_low = np.minimum(zpp, zqq)
    in_a = _above(a_lo[rows], a_hi[rows], z_low[:, None])[:, 0]
    in_b = _above(b_lo[rows], b_hi[rows], z_low[:, None])[:, 0]
    keep = in_a != in_b
    rows, t, zv, zpp, zqq, in_a = rows[keep], t[keep], zv[keep], zpp[keep], zqq[keep], in_a[keep]
    on_p = tag[rows, t] == 0
    pv, qv = p_xy[rows], q_xy[rows]
    v_xy = np.where(on_p[:, None], pv, qv)
    tri = np.stack([np.column_stack([pv, zpp]), np.column_stack([qv, zqq]),
                    np.column_stack([v_xy, zv])], axis=1)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, normal_axis]
    flip = (n > 0) != in_a  # facing out of a: along +axis; out of b: along -axis
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return tri


def _bands(d: Dexels, plo: np.ndarray, phi: np.ndarray):
    """Per band of column rows j0 .. j1 - 1: (j0, j1, the corner points of corner rows
    j0 .. j1, the walls across x and across y whose two columns differ, as (jj, ii, a_lo, a_hi,
    b_lo, b_hi) with jj the band's local row, a the column on the low side)."""
    band = max(1, _BAND_COLUMNS // max(d.nx, 1))
    for j0 in range(0, d.ny, band):
        j1 = min(d.ny, j0 + band)
        walls = []
        top = j1 + 1 if j1 == d.ny else j1  # the walls across y at Y[ny] go with the last band
        for a, b in (((slice(j0 + 1, j1 + 1), slice(None, -1)),
                      (slice(j0 + 1, j1 + 1), slice(1, None))),
                     ((slice(j0, top), slice(1, -1)), (slice(j0 + 1, top + 1), slice(1, -1)))):
            a_lo, a_hi, b_lo, b_hi = plo[a], phi[a], plo[b], phi[b]
            jj, ii = np.nonzero(((a_lo != b_lo) | (a_hi != b_hi)).any(-1))
            walls.append((jj, ii, a_lo[jj, ii], a_hi[jj, ii], b_lo[jj, ii], b_hi[jj, ii]))
        yield j0, j1, _corner_points(plo, phi, j0, j1), walls


def band_triangles(d: Dexels) -> Iterator[np.ndarray]:
    """The closed surface of the dexel solid `d` as triangles `(M, 3, 3)` float32, part frame,
    mm, counter-clockwise seen from outside (the module docstring gives the faces), a band of
    grid rows at a time."""
    plo, phi = _ends(d)
    X = d.x0 + np.arange(d.nx + 1) * d.h
    Y = d.y0 + np.arange(d.ny + 1) * d.h
    for j0, j1, zc, (across_x, across_y) in _bands(d, plo, phi):
        pieces = [_caps(plo, phi, X, Y, j0, j1)]
        jj, ii, *columns = across_x  # at x = X[i] between columns i - 1 and i
        pieces.append(_walls(zc[jj, ii], zc[jj + 1, ii], np.column_stack([X[ii], Y[jj + j0]]),
                             np.column_stack([X[ii], Y[jj + j0 + 1]]), *columns, 0))
        jj, ii, *columns = across_y  # at y = Y[j] between rows j - 1 and j
        pieces.append(_walls(zc[jj, ii], zc[jj, ii + 1], np.column_stack([X[ii], Y[jj + j0]]),
                             np.column_stack([X[ii + 1], Y[jj + j0]]), *columns, 1))
        yield np.concatenate(pieces).astype(np.float32)


def most_triangles(d: Dexels) -> int:
    """An upper bound of `band_triangles`' count: two per interval end (its cap) and, per wall,
    its two corner lines' points less two (the zipper's triangles)."""
    plo, phi = _ends(d)
    most = 2 * int(np.isfinite(plo).sum() + np.isfinite(phi).sum())
    for _, _, zc, (across_x, across_y) in _bands(d, plo, phi):
        n = np.isfinite(zc).sum(axis=-1)
        jj, ii = across_x[:2]
        most += int(np.maximum(n[jj, ii] + n[jj + 1, ii] - 2, 0).sum())
        jj, ii = across_y[:2]
        most += int(np.maximum(n[jj, ii] + n[jj, ii + 1] - 2, 0).sum())
    return most


def stock_triangles(d: Dexels) -> np.ndarray:
    """All of `band_triangles(d)` as one `(M, 3, 3)` float32 array."""
    return np.concatenate([np.zeros((0, 3, 3), np.float32), *band_triangles(d)])


def write_stl(dexels: Dexels, path: str | Path) -> Path:
    """Write the dexel stock's closed surface (`band_triangles`) to `path` as binary STL (numpy-
    stl's records and normals), whole or not at all (`checker.atomic`); the path written. The
    file is assembled in memory (50 bytes a triangle; room for `most_triangles` reserved, only
    what is written is touched)."""
    from stl import mesh as stl_mesh

    record = stl_mesh.Mesh.dtype.itemsize
    out = np.empty(_HEADER + most_triangles(dexels) * record, np.uint8)
    at = _HEADER
    for tri in band_triangles(dexels):
        m = stl_mesh.Mesh(np.zeros(len(tri), dtype=stl_mesh.Mesh.dtype), remove_empty_areas=False)
        m.vectors[:] = tri
        m.update_normals()
        out[at:at + len(tri) * record] = m.data.view(np.uint8)
        at += len(tri) * record
    out[:80] = np.frombuffer(b"pathcheck dexel stock".ljust(80), np.uint8)
    out[80:84] = np.frombuffer(np.uint32((at - _HEADER) // record).tobytes(), np.uint8)
    return write_file(path, memoryview(out[:at]), what="stock STL")
