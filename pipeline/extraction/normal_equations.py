"""The 3×3 symmetric solve of the pipeline's small least-squares fits (compiled kernels)."""

from __future__ import annotations

from pipeline.jit import kernel


@kernel
def solve_symmetric3(m00, m01, m02, m11, m12, m22, r0, r1, r2) -> tuple[float, float, float]:
    """Solution of the symmetric system [[m00, m01, m02], [m01, m11, m12], [m02, m12, m22]]·s
    = (r0, r1, r2) by Cramer's rule; NaN (or inf) where the system is singular.

    Fine for the normal equations of a quadratic fit over a few centred samples, whose
    condition stays far from the float64 limit.
    """
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    det = m00 * c00 + m01 * c01 + m02 * c02
    s0 = (r0 * c00 + r1 * c01 + r2 * c02) / det
    s1 = (r0 * c01 + r1 * (m00 * m22 - m02 * m02) + r2 * (m02 * m01 - m00 * m12)) / det
    s2 = (r0 * c02 + r1 * (m01 * m02 - m00 * m12) + r2 * (m00 * m11 - m01 * m01)) / det
    return s0, s1, s2
