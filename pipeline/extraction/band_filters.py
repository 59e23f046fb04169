"""Gaussian derivatives on the blocks of a band: the one separable filtering of the pipeline
with the kernels of `pipeline.extraction.gaussian`, evaluated where the stripe can be.

A band is a boolean grid of BLOCK_PX × BLOCK_PX blocks over one pyramid level. The x pass
runs on every row the y pass reads (the band's blocks widened by the kernel radius) into a
store of a few block rows, the y pass on each block row of the band right after the x rows
it reads. Inside the band the derivatives are those of the full frame
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


ROLLING_BLOCK_ROWS = 16
"""Block rows of x-pass rows the filtering keeps beyond the 2·radius a y pass reads more."""


def _rolling_rows(radius: int) -> int:
    """Rows of the x pass's rolling store for a kernel radius [px]."""
    return ROLLING_BLOCK_ROWS * BLOCK_PX + 2 * radius


@functools.cache
def _filter(radius: int) -> Callable[..., None]:
    """The band's separable filtering compiled for one kernel radius [px].

    The radius is a compile-time constant, so the tap loops unroll and the loops over the
    columns of a stretch vectorise (about 8× faster than a radius known only at run time).
    The kernel calls no other closure: numba caches a closure only when its captured values
    are plain constants, and these would otherwise compile anew in every process.
    """

    @kernel
    def filter_band(image, g0, g1, g2, blocks, need, rolling, ix, iy, ixx, ixy, iyy) -> None:
        """Ix, Iy, Ixx, Ixy, Iyy on the band's blocks, block row after block row.

        The x pass convolves the needed stretches of each x-pass row p (image row
        p − radius, folded at the border as BORDER) with G, G', G'' along x; the y pass of
        block row br reads x-pass rows 8·br … 8·br + 7 + 2·radius. The x pass keeps a few
        block rows of its rows (`rolling`, row p in slot p − base), so they are still in
        the cache when the y pass reads them; when the next rows would not fit, the
        stretches from 8·br on move to the first slots (base = 8·br). Each stretch is
        copied, folded, into a scratch row first (the frame is read in place, no padded
        copy), and every loop runs by unsigned flat offsets: no wrap-around test and no
        per-view alias checks each time a loop starts (band runs are short), so it
        vectorises even over a few blocks. A y loop writes two outputs of one input at
        most: more arrays in one loop exceed the alias checks the compiler will make.
        """
        height, width = image.shape
        source = image.ravel()
        smooth, d1, d2 = rolling[0].ravel(), rolling[1].ravel(), rolling[2].ravel()
        f_ix, f_iy, f_ixx, f_ixy, f_iyy = (
            ix.ravel(),
            iy.ravel(),
            ixx.ravel(),
            ixy.ravel(),
            iyy.ravel(),
        )
        scratch = np.empty(width + 2 * radius, np.float32)
        row_step = np.uint64(width)
        capacity = rolling[0].shape[0]
        stretches = block_runs(need)  # need: one row of blocks per x-pass row
        done = 0  # stretches of x-pass rows convolved so far
        kept = 0  # the first of them on a row ≥ base
        base = 0  # the x-pass row in slot 0
        for br, bc0, bc1 in block_runs(blocks):
            stop = min(br * BLOCK_PX + BLOCK_PX + 2 * radius, need.shape[0])
            if stop - base > capacity:
                while stretches[kept, 0] < br * BLOCK_PX:
                    kept += 1
                shift = np.uint64((br * BLOCK_PX - base) * width)
                for q in range(kept, done):
                    rp, first, last = stretches[q]
                    c0, c1 = first * BLOCK_PX, min(last * BLOCK_PX, width)
                    at = np.uint64((rp - base) * width + c0)
                    for i in range(np.uint64(c1 - c0)):
                        smooth[at + i - shift] = smooth[at + i]
                        d1[at + i - shift] = d1[at + i]
                        d2[at + i - shift] = d2[at + i]
                base = br * BLOCK_PX
            while done < stretches.shape[0] and stretches[done, 0] < stop:
                rp, first, last = stretches[done]
                done += 1
                c0, c1 = first * BLOCK_PX, min(last * BLOCK_PX, width)
                row = fold_index(rp - radius, height) * width
                lo, hi = max(c0 - radius, 0), min(c1 + radius, width)
                for j in range(lo - (c0 - radius)):  # folded columns left of the frame
                    scratch[j] = source[row + fold_index(c0 - radius + j, width)]
                into, start = np.uint64(lo - (c0 - radius)), np.uint64(row + lo)
                for j in range(np.uint64(hi - lo)):
                    scratch[into + j] = source[start + j]
                for j in range(hi - (c0 - radius), c1 - c0 + 2 * radius):  # right of it
                    scratch[j] = source[row + fold_index(c0 - radius + j, width)]
                out_at = np.uint64((rp - base) * width + c0)
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
                        s1 += g1[radius + k] * (left - right)  # G'(k) meets I(c − k)
                        s2 += g2[radius + k] * (left + right)
                    o = out_at + i
                    smooth[o], d1[o], d2[o] = s0, s1, s2
            c0, c1 = bc0 * BLOCK_PX, min(bc1 * BLOCK_PX, width)
            for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
                # Output row r is x-pass row r + radius.
                start = np.uint64(r - base + radius) * row_step + np.uint64(c0)
                out_at = np.uint64(r) * row_step + np.uint64(c0)
                for i in range(c1 - c0):  # d1 → Ix, Ixy
                    at = start + np.uint64(i)
                    s_even = g0[radius] * d1[at]
                    s_odd = np.float32(0.0)
                    for k in range(1, radius + 1):
                        up = d1[at - np.uint64(k) * row_step]
                        down = d1[at + np.uint64(k) * row_step]
                        s_even += g0[radius + k] * (up + down)
                        s_odd += g1[radius + k] * (up - down)
                    f_ix[out_at + np.uint64(i)] = s_even
                    f_ixy[out_at + np.uint64(i)] = s_odd
                for i in range(c1 - c0):  # smooth → Iyy, Iy
                    at = start + np.uint64(i)
                    s_even = g2[radius] * smooth[at]
                    s_odd = np.float32(0.0)
                    for k in range(1, radius + 1):
                        up = smooth[at - np.uint64(k) * row_step]
                        down = smooth[at + np.uint64(k) * row_step]
                        s_even += g2[radius + k] * (up + down)
                        s_odd += g1[radius + k] * (up - down)
                    f_iyy[out_at + np.uint64(i)] = s_even
                    f_iy[out_at + np.uint64(i)] = s_odd
                for i in range(c1 - c0):  # d2 → Ixx
                    at = start + np.uint64(i)
                    s_even = g0[radius] * d2[at]
                    for k in range(1, radius + 1):
                        up = d2[at - np.uint64(k) * row_step]
                        down = d2[at + np.uint64(k) * row_step]
                        s_even += g0[radius + k] * (up + down)
                    f_ixx[out_at + np.uint64(i)] = s_even

    return filter_band


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
    image: np.ndarray,
    sigma_px: float,
    blocks: np.ndarray,
    ring: np.ndarray,
    into: GaussianDerivatives | None = None,
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
    into : GaussianDerivatives, optional
        Derivatives of the same image and scale on other blocks (a refused band): written
        on `blocks` in place and returned (each pixel's figures depend on the image only).

    Returns
    -------
    GaussianDerivatives
        Five float32 (M, N) images, valid on the band (Ix, Iy on its ring too).
    """
    sigma, radius, (g0, g1, g2) = _float32_kernels(sigma_px)
    rows, cols = image.shape
    need = _row_needs(blocks, radius, rows + 2 * radius)
    rolling = tuple(np.empty((_rolling_rows(radius), cols), np.float32) for _ in range(3))
    if into is None:
        ix, iy, ixx, ixy, iyy = (np.empty((rows, cols), np.float32) for _ in range(5))
    else:
        ix, iy, ixx, ixy, iyy = into.ix, into.iy, into.ixx, into.ixy, into.iyy
    frame = np.ascontiguousarray(image)
    _filter(radius)(frame, g0, g1, g2, blocks, need, rolling, ix, iy, ixx, ixy, iyy)
    # Only the width search reads beyond the band, and only the gradient.
    for field in (ix, iy):
        zero_blocks(field, ring)
    if into is not None:
        return into
    return GaussianDerivatives(sigma_px=sigma, ix=ix, iy=iy, ixx=ixx, ixy=ixy, iyy=iyy)
