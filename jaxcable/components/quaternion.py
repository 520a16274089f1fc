"""Quaternions, scalar first ``[w, x, y, z]`` (body -> world), and the small rotation helpers the
multibody code and the beams share (arresting paper, eqs 35-38)."""

import jax.numpy as jnp



def quat_multiply(p, q):
    """Hamilton product ``p (x) q`` of (..., 4) quaternions."""
    pw, pv = p[..., :1], p[..., 1:]
    qw, qv = q[..., :1], q[..., 1:]
    w = pw * qw - jnp.sum(pv * qv, axis=-1, keepdims=True)
    v = pw * qv + qw * pv + jnp.cross(pv, qv)
    return jnp.concatenate([w, v], axis=-1)


def quat_conjugate(q):
    """``[w, -x, -y, -z]`` (the inverse of a unit quaternion)."""
    return q * jnp.array([1.0, -1.0, -1.0, -1.0], dtype=q.dtype)


def quat_to_matrix(q):
    """Rotation matrix (..., 3, 3) of a *unit* quaternion (..., 4): ``x_world = R x_body``."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return jnp.stack([jnp.stack(row, axis=-1) for row in rows], axis=-2)


# Below |angle| = 1e-6 rad (|v| = 5e-7) the closed forms are replaced by two-term series; the next
# terms are O(angle^4) ~ 1e-24, and the gradient stays finite (the sqrt never sees 0).
_SMALL_SQ = 1e-12


def quat_from_rotation_vector(rotation_vector):
    """Unit quaternion of the rotation by ``|theta|`` about ``theta/|theta|`` (..., 3) [rad].

    Gradient-safe at ``theta = 0`` (series ``w = 1 - a^2/8``, ``sin(a/2)/a = 1/2 - a^2/48``).
    """
    sq = jnp.sum(rotation_vector * rotation_vector, axis=-1, keepdims=True)
    small = sq < _SMALL_SQ
    angle = jnp.sqrt(jnp.where(small, 1.0, sq))
    w = jnp.where(small, 1.0 - sq / 8.0, jnp.cos(0.5 * angle))
    s = jnp.where(small, 0.5 - sq / 48.0, jnp.sin(0.5 * angle) / angle)
    return jnp.concatenate([w, s * rotation_vector], axis=-1)


def rotation_vector_from_quat(q):
    """Rotation vector (..., 3) [rad] of a unit quaternion (..., 4), angle in ``[0, pi]``.

    ``q`` and ``-q`` give the same result (the sign is chosen so that ``w >= 0``). Gradient-safe at
    the identity (series ``2 atan2(n, w)/n = 2/w (1 - n^2/(3 w^2))`` for small ``n = |[x, y, z]|``).
    """
    q = jnp.where(q[..., :1] < 0.0, -q, q)
    w, vec = q[..., :1], q[..., 1:]
    sq = jnp.sum(vec * vec, axis=-1, keepdims=True)
    small = sq < _SMALL_SQ
    n = jnp.sqrt(jnp.where(small, 1.0, sq))
    scale = jnp.where(small, 2.0 / w * (1.0 - sq / (3.0 * w * w)), 2.0 * jnp.arctan2(n, w) / n)
    return scale * vec


def _unit_quat(q):
    return q / jnp.linalg.norm(q, axis=-1, keepdims=True)


# Batched 3x3 products written as broadcast-multiply-sum: XLA fuses them with their neighbours,
# where an einsum becomes one small dot call each (the derivative is dominated by call overhead).
def _matvec(A, x):
    """``A[b] @ x[b]`` for (B,3,3) and (B,3)."""
    return jnp.sum(A * x[:, None, :], axis=-1)


def _matvec_t(A, x):
    """``A[b].T @ x[b]`` for (B,3,3) and (B,3)."""
    return jnp.sum(A * x[:, :, None], axis=-2)


def _matvec_points(A, p):
    """``A[b] @ p[b, i]`` for (B,3,3) and (B,P,3)."""
    return jnp.sum(A[:, None, :, :] * p[:, :, None, :], axis=-1)


def _matvec_t_points(A, p):
    """``A[b].T @ p[b, i]`` for (B,3,3) and (B,P,3)."""
    return jnp.sum(A[:, None, :, :] * p[:, :, :, None], axis=-2)
