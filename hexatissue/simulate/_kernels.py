"""numba kernels of the multiphase-field model (patch representation).

Data layout (docs/simulate.md, "Design"):

- ``phi[N, P, P]``: each cell's field on a P x P patch whose node ``(i, j)``
  sits on lattice row ``gy[c, i] = (oy[c] + i) mod Ly`` and column
  ``gx[c, j] = (ox[c] + j) mod Lx``.  ``ox, oy`` are *unwrapped* integer
  origins (they follow the cell across the periodic box).  The outer ring of
  every patch is held at 0 (Dirichlet), so only the interior nodes
  ``1..P-2`` evolve.
- Advection ``v_c . grad phi_c``: third-order upwind (``UPWIND3``; it reads
  the second neighbours ``i -+ 2``, clamped onto the zero ring next to it) or
  central differences (``CENTRAL``).
- ``S1 = sum_c phi_c`` and ``S2 = sum_c phi_c^2`` on the full lattice; the
  "other cells" terms are ``S2 - phi_c^2`` and ``lap(S1) - lap(phi_c)``.

Determinism: the lattice sums are *gathered* per band of ``CHUNK_ROWS``
lattice rows (a ``prange`` over bands; each band adds its cells in ascending
cell order), and every per-cell kernel writes only its own patch.  There are
no races and no atomics, and each lattice node is summed in the same order
whatever the number of threads, so results are bit-identical for any thread
count.  (Per-thread scatter buffers reduced at the end would be race-free
too, but their rounding would depend on how cells are split among threads.)

Every kernel here has a plain-numpy counterpart in ``_reference.py``.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

CHUNK_ROWS = 8  # lattice rows per band of the lattice sums (fixed: results must not depend on threads)

# indices into the per-dtype constant vector ``par`` (kept in the field dtype so float32 runs stay float32)
HALF_ALPHA, K_PHI, TWO_EPS, K_AD, MOB, DT, PHI0, FOUR, HALF, TWO, THREE, SIX, SIXTH = range(13)
N_PAR = 13

# advection schemes (Params.advection -> the ``scheme`` argument of the kernels)
CENTRAL, UPWIND3 = 0, 1
SCHEMES = {"central": CENTRAL, "upwind3": UPWIND3}


def pack_params(p, dtype) -> np.ndarray:
    """Constant vector ``par`` of the kernels, in the field dtype."""
    par = np.empty(N_PAR, dtype=dtype)
    par[HALF_ALPHA] = 0.5 * p.alpha
    par[K_PHI] = p.k_phi
    par[TWO_EPS] = 2.0 * p.eps
    par[K_AD] = p.k_ad
    par[MOB] = p.M
    par[DT] = p.dt
    par[PHI0] = p.phi0
    par[FOUR] = 4.0
    par[HALF] = 0.5
    par[TWO] = 2.0
    par[THREE] = 3.0
    par[SIX] = 6.0
    par[SIXTH] = 1.0 / 6.0
    return par


@njit(cache=True)
def index_rows(origin, L, P, out):
    """``out[c, i] = (origin[c] + i) mod L`` (wrapped lattice index of patch node i)."""
    for c in range(origin.shape[0]):
        for i in range(P):
            out[c, i] = (origin[c] + i) % L


@njit(cache=True)
def build_bands(oy, Ly, P, ptr, cells):
    """CSR lists band -> cells whose patch interior covers a row of the band (ascending cell order)."""
    nb = ptr.shape[0] - 1
    last = np.full(nb, -1, dtype=np.int64)
    count = np.zeros(nb, dtype=np.int64)
    N = oy.shape[0]
    for c in range(N):
        for i in range(1, P - 1):
            b = ((oy[c] + i) % Ly) // CHUNK_ROWS
            if last[b] != c:
                last[b] = c
                count[b] += 1
    ptr[0] = 0
    for b in range(nb):
        ptr[b + 1] = ptr[b] + count[b]
    last[:] = -1
    pos = ptr[:-1].copy()
    for c in range(N):
        for i in range(1, P - 1):
            b = ((oy[c] + i) % Ly) // CHUNK_ROWS
            if last[b] != c:
                last[b] = c
                cells[pos[b]] = c
                pos[b] += 1


@njit(cache=True, parallel=True, fastmath=True)
def lattice_sums(phi, oy, gx, ptr, cells, S1, S2, adhesion=True):
    """``S1 = sum_c phi_c``, ``S2 = sum_c phi_c^2`` on the lattice, gathered band by band.

    ``adhesion=False`` leaves ``S1`` untouched: only the adhesion term reads it (through ``lap S1``).
    """
    Ly, Lx = S1.shape[0], S1.shape[1]
    P = phi.shape[1]
    nb = ptr.shape[0] - 1
    for b in prange(nb):
        r0 = b * CHUNK_ROWS
        r1 = min(r0 + CHUNK_ROWS, Ly)
        if adhesion:
            S1[r0:r1, :] = 0
        S2[r0:r1, :] = 0
        for k in range(ptr[b], ptr[b + 1]):
            c = cells[k]
            q0 = gx[c, 0]
            straight = q0 + P <= Lx
            for r in range(r0, r1):
                i = (r - oy[c]) % Ly
                if i < 1 or i > P - 2:
                    continue
                if straight and adhesion:
                    # unsigned lattice column: a signed one gets numba's negative-index wraparound (no vectorising)
                    for j in range(np.uint64(1), np.uint64(P - 1)):
                        v = phi[c, i, j]
                        q = np.uint64(q0) + j
                        S1[r, q] += v
                        S2[r, q] += v * v
                elif straight:
                    for j in range(np.uint64(1), np.uint64(P - 1)):
                        v = phi[c, i, j]
                        S2[r, np.uint64(q0) + j] += v * v
                else:
                    for j in range(1, P - 1):
                        q = gx[c, j]
                        v = phi[c, i, j]
                        if adhesion:
                            S1[r, q] += v
                        S2[r, q] += v * v


@njit(cache=True, fastmath=True)
def _area(phi, c):
    """``int phi_c^2 dA`` in float64."""
    P = phi.shape[1]
    a = 0.0
    for i in range(1, P - 1):
        for j in range(1, P - 1):
            v = np.float64(phi[c, i, j])
            a += v * v
    return a


@njit(cache=True, parallel=True, fastmath=True)
def lattice_laplacian(S1, ptr, L):
    """``L = lap(S1)`` (5-point, periodic), band by band (the adhesion term of every cell reads it)."""
    Ly, Lx = S1.shape[0], S1.shape[1]
    nb = ptr.shape[0] - 1
    for b in prange(nb):
        for r in range(b * CHUNK_ROWS, min((b + 1) * CHUNK_ROWS, Ly)):
            rm = r - 1 if r > 0 else Ly - 1
            rp = r + 1 if r < Ly - 1 else 0
            L[r, 0] = S1[rm, 0] + S1[rp, 0] + S1[r, Lx - 1] + S1[r, 1] - 4 * S1[r, 0]
            for q in range(1, Lx - 1):
                L[r, q] = S1[rm, q] + S1[rp, q] + S1[r, q - 1] + S1[r, q + 1] - 4 * S1[r, q]
            L[r, Lx - 1] = S1[rm, Lx - 1] + S1[rp, Lx - 1] + S1[r, Lx - 2] + S1[r, 0] - 4 * S1[r, Lx - 1]


@njit(cache=True, fastmath=True)
def _mu_node(v, vn, vs, vw, ve, s2, lap_s1, par, ca):
    """``dF/dphi_c`` at a node from its value, its 4 neighbours, ``S2`` and ``lap S1`` there."""
    lap = (vn + vs + vw + ve) - par[FOUR] * v
    phi0 = par[PHI0]
    return (
        par[HALF_ALPHA] * v * (v - phi0) * ((v + v) - phi0)
        - par[K_PHI] * lap
        + par[TWO_EPS] * v * (s2 - v * v)
        - par[K_AD] * (lap_s1 - lap)
        - ca * v
    )


@njit(cache=True, fastmath=True)
def _rhs_node(phi, c, i, j, s2, lap_s1, par, ca, vx, vy):
    """``d phi_c / dt`` at patch node (i, j) with central-difference advection.

    The expression is kept exactly as it was before ``upwind3`` existed (not via :func:`_mu_node`):
    with it, central runs are bit-identical to runs made by earlier versions.
    """
    v = phi[c, i, j]
    vn = phi[c, i - 1, j]
    vs = phi[c, i + 1, j]
    vw = phi[c, i, j - 1]
    ve = phi[c, i, j + 1]
    lap = (vn + vs + vw + ve) - par[FOUR] * v
    phi0 = par[PHI0]
    mu = (
        par[HALF_ALPHA] * v * (v - phi0) * ((v + v) - phi0)
        - par[K_PHI] * lap
        + par[TWO_EPS] * v * (s2 - v * v)
        - par[K_AD] * (lap_s1 - lap)
        - ca * v
    )
    adv = par[HALF] * (vx * (ve - vw) + vy * (vs - vn))
    return -par[MOB] * mu - adv


def upwind3_weights(velocity):
    """Weights of ``f[-2], f[-1], f[0], f[+1], f[+2]`` in ``velocity x`` the third-order upwind derivative.

    velocity > 0 (upstream is the minus side): ``(f[-2] - 6 f[-1] + 3 f[0] + 2 f[+1]) / 6``;
    velocity <= 0: ``(-2 f[-1] - 3 f[0] + 6 f[+1] - f[+2]) / 6``.  Both are exact for cubics;
    the leading error ``+-f^(4) / 12`` makes the scheme add a hyperdiffusion
    ``-(|velocity| / 12) d^4 phi`` (docs/simulate.md).  Plain-Python twin of :func:`_upwind3_weights`.
    """
    s = velocity / 6.0
    if velocity > 0:
        return (s, -6.0 * s, 3.0 * s, 2.0 * s, 0.0)
    return (0.0, -2.0 * s, -3.0 * s, 6.0 * s, -s)


@njit(cache=True, fastmath=True)
def _upwind3_weights(velocity, par):
    """:func:`upwind3_weights` in the field dtype, without a branch: ``(w_m2, w_m1, w_0, w_p1, w_p2)``.

    Both one-sided stencils are blended with the weights ``max(velocity, 0)`` and ``min(velocity, 0)``
    (one of them is 0), so the node loop reads all five nodes at fixed offsets and vectorises.
    """
    zero = velocity - velocity  # 0 in the field dtype (a literal 0 would promote float32 to float64)
    pos = max(velocity, zero) * par[SIXTH]
    neg = min(velocity, zero) * par[SIXTH]
    return (pos, -par[SIX] * pos - par[TWO] * neg, par[THREE] * (pos - neg), par[TWO] * pos + par[SIX] * neg, -neg)


@njit(cache=True, fastmath=True)
def _stage_central(phi_eval, phi, out, c, S2, L, gx, gy, par, ca, cvx, cvy, second):
    """One Heun stage of cell c with central-difference advection (see :func:`heun_stage`)."""
    P = phi.shape[1]
    Lx = S2.shape[1]
    dt = par[DT]
    half = par[HALF]
    half_dt = half * dt
    q0 = gx[c, 0]
    # patches not cut by the box edge (most of them) index the lattice directly
    straight = q0 + P <= Lx
    for i in range(1, P - 1):
        r = gy[c, i]
        for j in range(1, P - 1):
            q = q0 + j if straight else gx[c, j]
            k = _rhs_node(phi_eval, c, i, j, S2[r, q], L[r, q], par, ca, cvx, cvy)
            if second:
                out[c, i, j] = half * (phi[c, i, j] + phi_eval[c, i, j]) + half_dt * k
            else:
                out[c, i, j] = phi[c, i, j] + dt * k


@njit(cache=True, fastmath=True)
def _rate_upwind3(f, s2, lap_s1, b, dn2, ds2, P, w, par, ca):
    """``d phi / dt`` at node ``b`` of a flat patch ``f`` (upwind3); ``b - dn2``, ``b + ds2``: its far row neighbours.

    ``s2``, ``lap_s1``: ``S2`` and ``lap S1`` in the patch layout; ``w``: the 9 advection weights
    (node, x -2..+2 without 0, y -2..+2 without 0).  Indices are unsigned (see :func:`_span_upwind3`).
    """
    w0, xm2, xm1, xp1, xp2, ym2, ym1, yp1, yp2 = w
    one = np.uint64(1)  # unsigned offsets: an int literal would make the index signed
    two = np.uint64(2)
    v = f[b]
    vn = f[b - P]
    vs = f[b + P]
    vw = f[b - one]
    ve = f[b + one]
    mu = _mu_node(v, vn, vs, vw, ve, s2[b], lap_s1[b], par, ca)
    adv = (w0 * v + xm1 * vw + xp1 * ve + ym1 * vn + yp1 * vs
           + xm2 * f[b - two] + xp2 * f[b + two] + ym2 * f[b - dn2] + yp2 * f[b + ds2])
    return -par[MOB] * mu - adv


@njit(cache=True, fastmath=True)
def _span_upwind3(o, src, f, s2, lap_s1, k0, k1, dn2, ds2, P, w, par, ca, second):
    """Stage update of the flat patch nodes ``k0 .. k1 - 1`` (whole rows, their ring columns included).

    First stage: ``o = src + dt rate(f)``; second: ``o = (o + f) / 2 + dt/2 rate(f)`` (``src`` unused: ``o``
    is read and written at the same node only, which LLVM can see, so it still vectorises).
    All indices are unsigned: they are >= 0 here, and numba's negative-index wraparound of signed
    indices turns the loads into gathers.
    """
    dt = par[DT]
    half = par[HALF]
    half_dt = half * dt
    uP = np.uint64(P)
    udn, uds = np.uint64(dn2), np.uint64(ds2)
    if second:
        for b in range(np.uint64(k0), np.uint64(k1)):
            o[b] = half * (o[b] + f[b]) + half_dt * _rate_upwind3(f, s2, lap_s1, b, udn, uds, uP, w, par, ca)
    else:
        for b in range(np.uint64(k0), np.uint64(k1)):
            o[b] = src[b] + dt * _rate_upwind3(f, s2, lap_s1, b, udn, uds, uP, w, par, ca)


@njit(cache=True)
def _gather(A, gx, gy, c, out):
    """``out[i P + j] = A[gy[c, i], gx[c, j]]`` on the interior rows ``i = 1 .. P-2`` (all columns).

    Explicit loops with unsigned indices: numba's slice assignment costs more than the copy itself
    for rows this short (a quarter of the stage's time).
    """
    P = gx.shape[1]
    Lx = A.shape[1]
    q0 = gx[c, 0]
    for i in range(1, P - 1):
        r = gy[c, i]
        base = np.uint64(i * P)
        if q0 + P <= Lx:
            row = A[r]
            uq0 = np.uint64(q0)
            for j in range(np.uint64(0), np.uint64(P)):
                out[base + j] = row[uq0 + j]
        else:
            for j in range(P):
                out[base + j] = A[r, gx[c, j]]


@njit(cache=True, fastmath=True)
def _stage_upwind3(phi_eval, phi, out, c, S2, L, gx, gy, par, ca, cvx, cvy, second, adhesion):
    """One Heun stage of cell c with third-order upwind advection (see :func:`heun_stage`).

    The patch is swept flat (node ``k = i P + j``) in three spans of whole rows: row 1, rows 2..P-3
    and row P-2, so every load has a fixed offset and the loop vectorises.  Beyond the zero ring
    the field is 0: the far row neighbour of rows 1 and P-2 is the ring row next to them, and
    along a row the far neighbour of the first or last interior column is the ring node at the end
    of the row before or the start of the row after.  The ring columns are swept too (their
    results are discarded: reset to 0 afterwards).  ``S2`` and ``lap S1`` are first copied into
    the patch layout; without ``adhesion`` (``k_ad = 0``) ``lap S1`` is not read (0 in its place:
    its only term is ``k_ad`` times it).
    """
    P = phi.shape[1]
    xm2, xm1, x0, xp1, xp2 = _upwind3_weights(cvx, par)
    ym2, ym1, y0, yp1, yp2 = _upwind3_weights(cvy, par)
    w = (x0 + y0, xm2, xm1, xp1, xp2, ym2, ym1, yp1, yp2)
    s2 = np.empty(P * P, dtype=S2.dtype)
    lap_s1 = np.empty(P * P, dtype=L.dtype) if adhesion else np.zeros(P * P, dtype=L.dtype)
    _gather(S2, gx, gy, c, s2)
    if adhesion:
        _gather(L, gx, gy, c, lap_s1)
    if second and out.ctypes.data != phi.ctypes.data:
        out[c] = phi[c]  # the second stage updates out in place from phi (advance passes out = phi)
    f = phi_eval[c].reshape(P * P)
    o = out[c].reshape(P * P)
    src = phi[c].reshape(P * P)
    _span_upwind3(o, src, f, s2, lap_s1, P, 2 * P, P, 2 * P, P, w, par, ca, second)
    _span_upwind3(o, src, f, s2, lap_s1, 2 * P, (P - 2) * P, 2 * P, 2 * P, P, w, par, ca, second)
    _span_upwind3(o, src, f, s2, lap_s1, (P - 2) * P, (P - 1) * P, 2 * P, P, P, w, par, ca, second)
    for i in range(1, P - 1):
        out[c, i, 0] = 0
        out[c, i, P - 1] = 0


@njit(cache=True, parallel=True, fastmath=True)
def heun_stage(phi_eval, phi, out, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, second):
    """One Heun stage for every cell (prange over cells; each writes only its own patch), central advection.

    First stage (``second=False``): ``out = phi + dt f(phi)`` (``phi_eval`` is ``phi``).
    Second stage (``second=True``), with ``phi_eval = phi + dt k1`` from the
    first: ``out = phi + dt/2 (k1 + f(phi_eval)) = (phi + phi_eval)/2 + dt/2 f(phi_eval)``,
    so ``k1`` is never stored (``out`` may be ``phi``: each node reads only
    ``phi_eval`` around it and ``phi`` at itself).  ``f`` is evaluated with
    ``S2`` and ``L = lap S1`` of ``phi_eval``.  ``area[c]`` receives
    ``int phi_eval_c^2 dA`` (float64).

    :func:`heun_stage_upwind3` is the same with upwind advection.  They are two kernels rather than
    one with a branch: with both loops in one function, LLVM's fast-math optimisation changed the
    rounding of the central path (float32 fields 2e-6 apart after 400 steps).
    """
    N = phi.shape[0]
    for c in prange(N):
        a = _area(phi_eval, c)
        area[c] = a
        # dF/dphi of lam (1 - A/A0)^2 is -4 lam/A0 (1 - A/A0) phi; coef keeps it in the field dtype
        coef[c] = lam4 * inv_a0 * (1.0 - a * inv_a0)
        _stage_central(phi_eval, phi, out, c, S2, L, gx, gy, par, coef[c], vx[c], vy[c], second)


@njit(cache=True, parallel=True, fastmath=True)
def heun_stage_upwind3(phi_eval, phi, out, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, second,
                       adhesion=True):
    """:func:`heun_stage` with third-order upwind advection (:func:`_stage_upwind3`; ``adhesion=False``: ``L`` unread)."""
    N = phi.shape[0]
    for c in prange(N):
        a = _area(phi_eval, c)
        area[c] = a
        coef[c] = lam4 * inv_a0 * (1.0 - a * inv_a0)
        _stage_upwind3(phi_eval, phi, out, c, S2, L, gx, gy, par, coef[c], vx[c], vy[c], second, adhesion)


@njit(cache=True)
def _stage(phi_eval, phi, out, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, second, scheme, adhesion):
    """:func:`heun_stage` or :func:`heun_stage_upwind3`, by ``scheme`` (``CENTRAL``, ``UPWIND3``)."""
    if scheme == UPWIND3:
        heun_stage_upwind3(phi_eval, phi, out, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, second, adhesion)
    else:
        heun_stage(phi_eval, phi, out, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, second)


@njit(cache=True)
def _patch_moments(phi, c):
    """Float64 sums over cell c's patch interior: ``int phi^2``, ``sum phi^2 j``, ``sum phi^2 i`` and
    ``int phi^2`` on the two interior rings next to the fixed zero ring (the leak measure)."""
    P = phi.shape[1]
    a = 0.0
    mx = 0.0
    my = 0.0
    rim = 0.0
    for i in range(1, P - 1):
        for j in range(1, P - 1):
            v = np.float64(phi[c, i, j])
            w = v * v
            a += w
            mx += w * j
            my += w * i
            if i <= 2 or j <= 2 or i >= P - 3 or j >= P - 3:
                rim += w
    return a, mx, my, rim


@njit(cache=True, parallel=True)
def moments(phi, ox, oy, out):
    """Per cell ``out[c] = (area, x, y)``: ``int phi^2 dA`` and the phi^2-weighted centroid (float64).

    x = column, y = row, unwrapped (``ox + j``, ``oy + i``), origin at the
    centre of lattice node (0, 0).
    """
    N, P = phi.shape[0], phi.shape[1]
    for c in prange(N):
        a, mx, my, _ = _patch_moments(phi, c)
        out[c, 0] = a
        if a > 0:
            out[c, 1] = ox[c] + mx / a
            out[c, 2] = oy[c] + my / a
        else:
            out[c, 1] = ox[c] + 0.5 * (P - 1)
            out[c, 2] = oy[c] + 0.5 * (P - 1)


@njit(cache=True, parallel=True)
def recentre(phi, scratch, ox, oy, leak, threshold):
    """Shift each patch by whole nodes so that its phi^2 centroid is within ``threshold`` of the centre.

    Updates ``phi`` (nodes shifted out of the patch are dropped, new nodes are
    0), ``ox, oy``; ``leak[c]`` becomes the max of itself and the fraction of
    ``int phi^2`` on the two interior rings next to the fixed zero ring.
    Returns the number of patches moved.
    """
    N, P = phi.shape[0], phi.shape[1]
    centre = 0.5 * (P - 1)
    moved = np.zeros(N, dtype=np.int64)
    for c in prange(N):
        a, mx, my, rim = _patch_moments(phi, c)
        if a <= 0:
            continue
        leak[c] = max(leak[c], rim / a)
        dx = mx / a - centre
        dy = my / a - centre
        if abs(dx) < threshold and abs(dy) < threshold:
            continue
        sx = int(np.round(dx))
        sy = int(np.round(dy))
        if sx == 0 and sy == 0:
            continue
        for i in range(P):
            for j in range(P):
                scratch[c, i, j] = phi[c, i, j]
        for i in range(P):
            for j in range(P):
                si = i + sy
                sj = j + sx
                if 1 <= i <= P - 2 and 1 <= j <= P - 2 and 1 <= si <= P - 2 and 1 <= sj <= P - 2:
                    phi[c, i, j] = scratch[c, si, sj]
                else:
                    phi[c, i, j] = 0
        ox[c] += sx
        oy[c] += sy
        moved[c] = 1
    return moved.sum()


@njit(cache=True)
def set_velocity(theta, v0, vx, vy):
    for c in range(theta.shape[0]):
        vx[c] = v0 * np.cos(theta[c])
        vy[c] = v0 * np.sin(theta[c])


@njit(cache=True)
def _sums(phi, oy, gx, ptr, cells, S1, S2, L, adhesion):
    """The lattice sums a stage reads: ``S2``, and with ``adhesion`` ``S1`` and ``L = lap S1``."""
    lattice_sums(phi, oy, gx, ptr, cells, S1, S2, adhesion)
    if adhesion:
        lattice_laplacian(S1, ptr, L)


@njit(cache=True, nogil=True)  # nogil: the run's writer thread stores frames meanwhile
def advance(phi, phis, S1, S2, L, ox, oy, gx, gy, ptr, cells, theta, noise, coef, vx, vy, area, leak,
            par, inv_a0, lam4, v0, sigma, step0, nsteps, recentre_every, threshold, scheme, euler):
    """``nsteps`` Heun steps (explicit Euler steps if ``euler``) from global step ``step0``.

    Fields, origins and theta are updated in place.  Step s uses theta_s (for both
    stages), then ``theta += sigma * noise[s]`` (``sigma = sqrt(2 D_r dt)``; pass an empty ``noise`` with ``sigma = 0``
    for passive steps).  After every step whose global index ``step0 + s + 1``
    is a multiple of ``recentre_every`` the patches are re-centred (``phis``
    is their scratch space).  ``scheme`` selects the advection stencil (``CENTRAL``, ``UPWIND3``).
    Returns the number of patch moves.
    """
    Lx, Ly = S1.shape[1], S1.shape[0]
    P = phi.shape[1]
    # k_ad = 0 (e.g. the C code's functional): S1 and lap S1 only feed the adhesion term, skip them
    # (exact: the term is 0 times a finite number either way; L stays as it is)
    adhesion = par[K_AD] != 0
    moves = 0
    result = phi  # Euler steps swap phi and phis (no copy per step); the result goes back here at the end
    for s in range(nsteps):
        set_velocity(theta, v0, vx, vy)
        _sums(phi, oy, gx, ptr, cells, S1, S2, L, adhesion)
        _stage(phi, phi, phis, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, False, scheme, adhesion)
        if euler:
            phi, phis = phis, phi
        else:
            _sums(phis, oy, gx, ptr, cells, S1, S2, L, adhesion)
            _stage(phis, phi, phi, S2, L, gx, gy, coef, vx, vy, area, par, inv_a0, lam4, True, scheme, adhesion)
        if sigma > 0:
            for c in range(theta.shape[0]):
                theta[c] += sigma * noise[s, c]
        if (step0 + s + 1) % recentre_every == 0:
            n = recentre(phi, phis, ox, oy, leak, threshold)
            if n > 0:
                moves += n
                index_rows(ox, Lx, P, gx)
                index_rows(oy, Ly, P, gy)
                build_bands(oy, Ly, P, ptr, cells)
    if phi.ctypes.data != result.ctypes.data:
        result[:] = phi
    return moves


@njit(cache=True, parallel=True)
def max_field(phi, oy, gx, ptr, cells, vmax, imax, vsum):
    """Per lattice node the largest field ``vmax``, its cell ``imax`` (-1 where none) and the total ``vsum``.

    Ties go to the lower cell index (cells are visited in ascending order).
    """
    Ly = vmax.shape[0]
    P = phi.shape[1]
    nb = ptr.shape[0] - 1
    for b in prange(nb):
        r0 = b * CHUNK_ROWS
        r1 = min(r0 + CHUNK_ROWS, Ly)
        vmax[r0:r1, :] = 0
        vsum[r0:r1, :] = 0
        imax[r0:r1, :] = -1
        for k in range(ptr[b], ptr[b + 1]):
            c = cells[k]
            for r in range(r0, r1):
                i = (r - oy[c]) % Ly
                if i < 1 or i > P - 2:
                    continue
                for j in range(1, P - 1):
                    q = gx[c, j]
                    v = np.float64(phi[c, i, j])
                    vsum[r, q] += v
                    if v > vmax[r, q]:
                        vmax[r, q] = v
                        imax[r, q] = c
