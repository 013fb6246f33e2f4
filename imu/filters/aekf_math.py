"""The error-state EKF's small numeric kernels (:mod:`imutherm.imu.filters.aekf`): 3x3 products written out,
the rotation-vector exponential, the covariance propagation and the Joseph-form update (compiled with numba;
numba's @ on these small matrices calls BLAS, ~1 us of overhead a product)."""

from __future__ import annotations

import numpy as np
from imutherm.lazy_jit import njit


@njit(cache=True)
def skew(v):
    m = np.zeros((3, 3))
    m[0, 1], m[0, 2], m[1, 0], m[1, 2], m[2, 0], m[2, 1] = -v[2], v[1], v[2], -v[0], -v[1], v[0]
    return m


@njit(cache=True)
def rotvec_dcm(a):
    """exp([a×]) (3,3) for a rotation vector a [rad]."""
    th = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    K = skew(a)
    if th < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + np.sin(th) / th * K + (1.0 - np.cos(th)) / (th * th) * mm3(K, K)


@njit(cache=True)
def mm3(A, B):
    """A @ B for 3x3 matrices, written out (numba's @ calls BLAS: ~1 us of overhead per call)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True)
def mv3(A, x):
    """A @ x for a 3x3 matrix and a 3-vector, written out."""
    out = np.empty(3)
    for i in range(3):
        out[i] = A[i, 0] * x[0] + A[i, 1] * x[1] + A[i, 2] * x[2]
    return out


@njit(cache=True)
def align_rotation(a, b):
    """The smallest rotation (3,3) taking the direction of a (3,) to that of b (3,) (a half turn about an axis
    perpendicular to a when they are opposite)."""
    a = a / np.sqrt(a @ a)
    b = b / np.sqrt(b @ b)
    v = np.cross(a, b)
    c = a @ b
    if v @ v < 1e-18:
        if c > 0:
            return np.eye(3)
        u = np.cross(a, np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
        u = u / np.sqrt(u @ u)
        return 2.0 * np.outer(u, u) - np.eye(3)
    K = skew(v)
    return np.eye(3) + K + mm3(K, K) / (1.0 + c)


@njit(cache=True)
def orthonormalise(C):
    u, s, vt = np.linalg.svd(C)
    return u @ vt


@njit(cache=True)
def propagate_cov(P, C, S, h, G, Hp):
    """P <- Phi P Phi^T in place, Phi = I + F h, for the error state (attitude, velocity, gyro bias) whose
    F has two non-zero blocks: F[0:3, 6:9] = -C (bias into attitude), F[3:6, 0:3] = -S (S = [C f x],
    attitude into velocity). Phi P Phi^T = P + h (F P + (F P)^T) + h^2 F P F^T for a symmetric P, with
    F P and F P F^T formed from those blocks alone (the dense 9x9 products cost ~2 us per sample).
    G (6, 9), Hp (6, 6): work space."""
    for i in range(3):
        for j in range(9):
            a = 0.0
            b = 0.0
            for m in range(3):
                a += C[i, m] * P[6 + m, j]
                b += S[i, m] * P[m, j]
            G[i, j] = -a          # (F P)[i, j], i < 3
            G[3 + i, j] = -b      # (F P)[3 + i, j]
    for c in range(6):            # (F P F^T)[r, c] = sum_m F[r, m] (F P)[c, m]
        for i in range(3):
            a = 0.0
            b = 0.0
            for m in range(3):
                a += C[i, m] * G[c, 6 + m]
                b += S[i, m] * G[c, m]
            Hp[i, c] = -a
            Hp[3 + i, c] = -b
    for r in range(9):
        for c in range(r, 9):
            x = P[r, c]
            if r < 6:
                x += h * G[r, c]
            if c < 6:
                x += h * G[c, r] + h * h * Hp[r, c]
            P[r, c] = x
            P[c, r] = x


@njit(cache=True)
def mat_mul(A, B, transpose_b=False):
    """A @ B (or A @ B.T) written out: numba's @ on these small matrices calls BLAS, ~1 us of overhead a
    product, more than the product itself."""
    n, l = A.shape
    m = B.shape[0] if transpose_b else B.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            a = 0.0
            for k in range(l):
                a += A[i, k] * (B[j, k] if transpose_b else B[k, j])
            out[i, j] = a
    return out


@njit(cache=True)
def hpht(H, P):
    """H P H^T (3, 3) for H (3, 9), P (9, 9)."""
    return mat_mul(mat_mul(H, P), H, True)


@njit(cache=True)
def joseph_update(P, H, Sinv, r, nu, I9):
    """The Kalman update in Joseph form, P <- (I - K H) P (I - K H)^T + K diag(r) K^T (symmetrised) in
    place, K = P H^T S^-1; returns the state correction K nu (9,). H (3, 9), Sinv (3, 3), r (3,) the
    measurement variances, nu (3,) the innovation. Written out (:func:`mat_mul`)."""
    K = mat_mul(mat_mul(P, H, True), Sinv)
    dx = np.zeros(9)
    for i in range(9):
        dx[i] = K[i, 0] * nu[0] + K[i, 1] * nu[1] + K[i, 2] * nu[2]
    IKH = I9 - mat_mul(K, H)
    T = mat_mul(IKH, P)
    for i in range(9):
        for j in range(i, 9):
            a = K[i, 0] * r[0] * K[j, 0] + K[i, 1] * r[1] * K[j, 1] + K[i, 2] * r[2] * K[j, 2]
            c = 0.0
            e = 0.0
            for m in range(9):
                c += T[i, m] * IKH[j, m]
                e += T[j, m] * IKH[i, m]
            x = 0.5 * (c + e) + a
            P[i, j] = x
            P[j, i] = x
    return dx


@njit(cache=True)
def reset_attitude(P, H, R, wgt, p0_yaw):
    """The attitude-covariance reset after a divergence (the NIS monitor) or a long rejection (the re-level), in
    place: P's attitude rows and columns zeroed, the tilt variances set to (10°)², the yaw variance to p0_yaw
    [rad^2]; returns (H P Hᵀ, S = H P Hᵀ + diag(R / wgt)) for the measurement H (3, 9), R (3,) its variances and
    wgt its weight."""
    for i in range(3):
        for j in range(9):
            P[i, j] = 0.0
            P[j, i] = 0.0
    P[0, 0] = P[1, 1] = (10.0 * np.pi / 180.0) ** 2
    P[2, 2] = p0_yaw
    HPH = hpht(H, P)
    S = HPH.copy()
    for i in range(3):
        S[i, i] += R[i] / wgt
    return HPH, S


@njit(cache=True)
def record_reset(resets, n, k):
    """Report sample k as a reset: resets[n] = k while there is room; returns the new count."""
    if n < resets.shape[0]:
        resets[n] = k
        return n + 1
    return n
