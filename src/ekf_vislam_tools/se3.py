"""SO(3)/SE(3) helpers (numpy), conventions of the C++ core: twist u = [v; w], xi = [rho; phi]."""
import numpy as np


def hat(w):
    """3-vector -> 3x3 skew matrix."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def so3_exp(phi):
    phi = np.asarray(phi, dtype=float)
    theta = np.linalg.norm(phi)
    K = hat(phi)
    if theta < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return (np.eye(3) + np.sin(theta) / theta * K
            + (1.0 - np.cos(theta)) / theta ** 2 * K @ K)


def so3_log(R):
    cos_theta = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos_theta)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if theta < 1e-8:
        return 0.5 * w
    if np.pi - theta < 1e-6:
        # Near pi: axis from the symmetric part.
        B = 0.5 * (R + np.eye(3))
        axis = np.sqrt(np.maximum(np.diag(B), 0.0))
        i = int(np.argmax(axis))
        axis = B[:, i] / max(axis[i], 1e-12)
        axis /= np.linalg.norm(axis)
        return theta * axis
    return theta / (2.0 * np.sin(theta)) * w


def so3_left_jacobian(phi):
    """V = J_l(phi): the translation of se3_exp([rho; phi]) is V rho."""
    theta = np.linalg.norm(phi)
    K = hat(phi)
    if theta < 1e-8:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return (np.eye(3) + (1.0 - np.cos(theta)) / theta ** 2 * K
            + (theta - np.sin(theta)) / theta ** 3 * K @ K)


def se3_exp(xi):
    """xi = [rho; phi] -> 4x4."""
    xi = np.asarray(xi, dtype=float)
    rho, phi = xi[:3], xi[3:]
    V = so3_left_jacobian(phi)
    T = np.eye(4)
    T[:3, :3] = so3_exp(phi)
    T[:3, 3] = V @ rho
    return T


def twist_exp(v, w, tau):
    """exp(tau [w^ v; 0 0]): the motion over tau seconds at body twist (v, w)."""
    return se3_exp(np.concatenate([np.asarray(v, float), np.asarray(w, float)]) * tau)


def inverse(T):
    Ti = np.eye(4)
    Ti[:3, :3] = T[:3, :3].T
    Ti[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return Ti


def rotation_to_quaternion(R):
    """3x3 -> (qx, qy, qz, qw), qw >= 0."""
    m = R
    tr = np.trace(m)
    if tr > 0:
        s = np.sqrt(tr + 1.0) * 2
        qw, qx, qy, qz = 0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        qw, qx, qy, qz = (m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s
    elif m[1, 1] > m[2, 2]:
        s = np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        qw, qx, qy, qz = (m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s
    else:
        s = np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        qw, qx, qy, qz = (m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s
    q = np.array([qx, qy, qz, qw])
    q /= np.linalg.norm(q)
    return q if q[3] >= 0 else -q


def quaternion_to_rotation(q):
    """(qx, qy, qz, qw) -> 3x3."""
    x, y, z, w = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def se3_log(T):
    """4x4 -> xi = [rho; phi] with T = se3_exp(xi)."""
    T = np.asarray(T, dtype=float)
    phi = so3_log(T[:3, :3])
    return np.concatenate([np.linalg.solve(so3_left_jacobian(phi), T[:3, 3]), phi])
