"""Turning SH coefficients from glTF's frame (+Y up, the exported scene's) into Blender's
(+Z up): real orthonormal SH with the Condon–Shortley phase, index l(l+1)+m, θ from +z (the
project's convention). A glTF position (x, y, z) is Blender's (x, −z, y)."""

import math

import numpy as np

# Blender's coordinates of a glTF direction: b = GLTF_TO_BLENDER @ g.
GLTF_TO_BLENDER = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)


def basis(directions, order):
    """(N, n²) real SH of unit directions (N, 3)."""
    x, y, z = directions.T
    phi = np.arctan2(y, x)
    out = np.zeros((len(directions), order * order))
    for m in range(order):
        # P_m^m with the Condon–Shortley phase, then the recurrence up in l.
        pmm = (-1) ** m * math.prod(range(1, 2 * m, 2)) * np.sqrt(np.maximum(1 - z * z, 0)) ** m
        p_prev, p = None, pmm
        for l in range(m, order):
            if l == m + 1:
                p_prev, p = p, z * (2 * m + 1) * pmm
            elif l > m + 1:
                p_prev, p = p, ((2 * l - 1) * z * p - (l + m - 1) * p_prev) / (l - m)
            k = math.sqrt((2 * l + 1) / (4 * math.pi)
                          * math.factorial(l - m) / math.factorial(l + m))
            if m == 0:
                out[:, l * (l + 1)] = k * p
            else:
                out[:, l * (l + 1) + m] = math.sqrt(2) * k * p * np.cos(m * phi)
                out[:, l * (l + 1) - m] = math.sqrt(2) * k * p * np.sin(m * phi)
    return out


def gltf_to_blender(order):
    """(n², n²) A with c_blender = A @ c_gltf for a function's coefficients (exact: a
    rotation keeps each band, and 4n² directions determine it)."""
    rng = np.random.default_rng(0)
    d = rng.normal(size=(4 * order * order + 16, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    # f_blender(d) = f_gltf(Mᵀ d): evaluate the glTF basis at the turned directions.
    a, *_ = np.linalg.lstsq(basis(d, order), basis(d @ GLTF_TO_BLENDER, order), rcond=None)
    return a
