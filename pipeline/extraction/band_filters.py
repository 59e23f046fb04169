"""Gaussian derivatives on the blocks of a band: the one separable filtering of the pipeline
with the kernels of `pipeline.extraction.gaussian`, evaluated where the stripe can be.

A band is a boolean grid of BLOCK_PX × BLOCK_PX blocks over one pyramid level. The x pass
runs on every row the y pass reads (the band's blocks widened by the kernel radius), the
y pass on the band's blocks. Inside the band the derivatives are those of the full frame
(the band of all blocks), bit for bit; outside they are 0.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from pipeline.extraction.blocks import BLOCK_PX, block_runs, zero_blocks
from pipeline.extraction.gaussian import GaussianDerivatives, gaussian_kernels
from pipeline.extraction.scalespace import fold_index
from pipeline.jit import kernel


@kernel
def _row_needs(blocks, reach_px, padded_rows):
    """Blocks per padded row whose x pass the y pass reads (rows shifted down by `reach_px`)."""
    need = np.zeros((padded_rows, blocks.shape[1]), np.bool_)
    for br in range(blocks.shape[0]):
        for bc in range(blocks.shape[1]):
            if blocks[br, bc]:
                stop = min(br * BLOCK_PX + BLOCK_PX + 2 * reach_px, padded_rows)
                need[br * BLOCK_PX : stop, bc] = True
    return need


@functools.cache
def _passes(radius: int) -> tuple[Callable[..., None], ...]:
    """The x pass and the two y passes compiled for one kernel radius [px].

    The radius is a compile-time constant, so the tap loop unrolls and the loop over the
    columns of a stretch vectorises (about 8× faster than a radius known only at run time).
    The passes call no other closure: numba caches a closure only when its captured values
    are plain constants, and these would otherwise compile anew in every process.
    """

    @kernel
    def x_pass(image, g0, g1, g2, need, out0, out1, out2) -> None:
        """Convolve the needed stretches of each x-pass row with G, G', G'' along x.

        X-pass row p is image row p − radius; rows and columns fold at the border as BORDER.
        Each stretch is copied, folded, into a scratch row first (the frame is read in
        place, no padded copy), and convolved there by unsigned offsets: no wrap-around
        test and no per-view alias checks each time the loop starts (band runs are short),
        so it vectorises even over a few blocks.
        """
        height, width = image.shape
        source, f0, f1, f2 = image.ravel(), out0.ravel(), out1.ravel(), out2.ravel()
        scratch = np.empty(width + 2 * radius, np.float32)
        for rp, bc0, bc1 in block_runs(need):  # need: one row of blocks per x-pass row
            c0, c1 = bc0 * BLOCK_PX, min(bc1 * BLOCK_PX, width)
            row = fold_index(rp - radius, height) * width
            lo, hi = max(c0 - radius, 0), min(c1 + radius, width)
            for j in range(lo - (c0 - radius)):  # folded columns left of the frame
                scratch[j] = source[row + fold_index(c0 - radius + j, width)]
            into, start = np.uint64(lo - (c0 - radius)), np.uint64(row + lo)
            for j in range(np.uint64(hi - lo)):
                scratch[into + j] = source[start + j]
            for j in range(hi - (c0 - radius), c1 - c0 + 2 * radius):  # right of the frame
                scratch[j] = source[row + fold_index(c0 - radius + j, width)]
            out_at = np.uint64(rp * width + c0)
            for i in range(np.uint64(c1 - c0)):
                at = np.uint64(radius) + i
                centre = scratch[at]
                s0 = g0[radius] * centre
                s1 = np.float32(0.0)
                s2 = g2[radius] * centre
                for k in range(1, radius + 1):
                    left = scratch[at - np.uint64(k)]
                    right = scratch[at + np.uint64(k)]
                    s0 += g0[radius + k] * (left + right)
                    s1 += g1[radius + k] * (left - right)  # convolution: G'(k) meets I(c − k)
                    s2 += g2[radius + k] * (left + right)
                o = out_at + i
                f0[o], f1[o], f2[o] = s0, s1, s2

    def y_pass_with(odd: bool) -> Callable[..., None]:
        """The y pass with one even and (`odd`) one odd kernel; `odd` is a compile-time
        constant, so the even-only pass carries no odd sums and no branch."""

        @kernel
        def y_pass(t, g_even, g_odd, blocks, out_even, out_odd) -> None:
            """Convolve x-pass rows along y with an even (and an odd) kernel on the band's
            blocks; without `odd`, `g_odd` and `out_odd` are not read.

            Two outputs of one input per call at most: more arrays in one loop exceed the
            alias checks the compiler will make, and the loop stops vectorising. Indices are
            unsigned flat offsets, as in `x_pass`.
            """
            height, width = out_even.shape
            flat, even, odd_out = t.ravel(), out_even.ravel(), out_odd.ravel()
            row_step = np.uint64(width)
            for br, bc0, bc1 in block_runs(blocks):
                c0, c1 = bc0 * BLOCK_PX, min(bc1 * BLOCK_PX, width)
                for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
                    # Row r sits at r + radius of the x-pass rows.
                    start = np.uint64(r + radius) * row_step + np.uint64(c0)
                    out_at = np.uint64(r) * row_step + np.uint64(c0)
                    for i in range(c1 - c0):
                        at = start + np.uint64(i)
                        s_even = g_even[radius] * flat[at]
                        s_odd = np.float32(0.0)
                        for k in range(1, radius + 1):
                            up = flat[at - np.uint64(k) * row_step]
                            down = flat[at + np.uint64(k) * row_step]
                            s_even += g_even[radius + k] * (up + down)
                            if odd:
                                s_odd += g_odd[radius + k] * (up - down)
                        even[out_at + np.uint64(i)] = s_even
                        if odd:
                            odd_out[out_at + np.uint64(i)] = s_odd

        return y_pass

    return x_pass, y_pass_with(odd=True), y_pass_with(odd=False)


@functools.lru_cache(maxsize=64)
def _float32_kernels(sigma_px: float) -> tuple[float, int, tuple[np.ndarray, ...]]:
    """σ [px], radius [px] and G, G', G'' of `gaussian_kernels` as float32 (read-only).

    Convolution by reversed kernels: G and G'' are symmetric, G' antisymmetric.
    """
    kernels = gaussian_kernels(sigma_px)
    taps = tuple(np.asarray(k, np.float32) for k in (kernels.g0, kernels.g1, kernels.g2))
    for k in taps:
        k.flags.writeable = False
    return kernels.sigma_px, kernels.radius_px, taps


def band_derivatives(
    image: np.ndarray, sigma_px: float, blocks: np.ndarray, ring: np.ndarray
) -> GaussianDerivatives:
    """Ix, Iy, Ixx, Ixy, Iyy of `image` at scale `sigma_px` on the band's blocks.

    Parameters
    ----------
    image : ndarray of shape (M, N), uint8, uint16 or float32
        Grey image of one pyramid level [grey levels].
    sigma_px : float
        Gaussian scale [px of that level].
    blocks : ndarray of shape (ceil(M/8), ceil(N/8)), bool
        The band: blocks where the derivatives are wanted.
    ring : ndarray of bool, the shape of `blocks`
        Blocks where Ix and Iy are set to 0 around the band (see `band.RING_BLOCKS`).

    Returns
    -------
    GaussianDerivatives
        Five float32 (M, N) images, valid on the band (Ix, Iy on its ring too).
    """
    sigma, radius, (g0, g1, g2) = _float32_kernels(sigma_px)
    rows, cols = image.shape
    need = _row_needs(blocks, radius, rows + 2 * radius)
    along_x = tuple(np.empty((rows + 2 * radius, cols), np.float32) for _ in range(3))
    ix, iy, ixx, ixy, iyy = (np.empty((rows, cols), np.float32) for _ in range(5))
    frame = np.ascontiguousarray(image)
    x_pass, y_pass, y_even = _passes(radius)
    smooth_x, d1_x, d2_x = along_x
    x_pass(frame, g0, g1, g2, need, smooth_x, d1_x, d2_x)
    y_pass(d1_x, g0, g1, blocks, ix, ixy)
    y_pass(smooth_x, g2, g1, blocks, iyy, iy)
    y_even(d2_x, g0, g0, blocks, ixx, ixx)  # the odd kernel and output are not read
    # Only the width search reads beyond the band, and only the gradient.
    for field in (ix, iy):
        zero_blocks(field, ring)
    return GaussianDerivatives(sigma_px=sigma, ix=ix, iy=iy, ixx=ixx, ixy=ixy, iyy=iyy)
