"""The block grid of a band: BLOCK_PX × BLOCK_PX blocks over one pyramid level, their runs
along block rows, and the per-block reads and writes the band's kernels share.

A grid of all blocks is the whole frame: every kernel of the method runs over a band, and the
full-frame analysis is the band of all blocks.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.jit import kernel

BLOCK_PX = 8
"""Side of a band block [px of its level]."""


def all_blocks(shape: tuple[int, int]) -> np.ndarray:
    """The block grid covering an image of `shape` wholly (bool, every block set)."""
    return np.ones(block_grid(shape), np.bool_)


@kernel
def block_runs(blocks):
    """Runs of consecutive True blocks along each block row: rows of (block_row, first, stop)."""
    runs = np.empty((blocks.size // 2 + blocks.shape[0], 3), np.int64)
    count = 0
    for br in range(blocks.shape[0]):
        bc = 0
        while bc < blocks.shape[1]:
            if not blocks[br, bc]:
                bc += 1
                continue
            start = bc
            while bc < blocks.shape[1] and blocks[br, bc]:
                bc += 1
            runs[count, 0], runs[count, 1], runs[count, 2] = br, start, bc
            count += 1
    return runs[:count]


@kernel
def run_starts(runs, rows):
    """Where each of `rows` block rows begins in `runs` (sorted by row): (rows + 1,) int64,
    so the runs of block row br are runs[starts[br]:starts[br + 1]]."""
    return np.searchsorted(runs[:, 0], np.arange(rows + 1))


@kernel
def zero_blocks(field, blocks) -> None:
    """Set the pixels of the given blocks to 0."""
    height, width = field.shape
    for br, first, stop in block_runs(blocks):
        c0, c1 = first * BLOCK_PX, min(stop * BLOCK_PX, width)
        for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
            field[r, c0:c1] = 0


def block_grid(shape: tuple[int, int]) -> tuple[int, int]:
    """Shape of the block grid over an image of `shape` (rows, columns)."""
    return math.ceil(shape[0] / BLOCK_PX), math.ceil(shape[1] / BLOCK_PX)


@kernel
def _pool(band, ratio, rows, cols):
    out = np.zeros((rows, cols), np.bool_)
    for r in range(band.shape[0]):
        for c in range(band.shape[1]):
            if band[r, c]:
                out[min(r // ratio, rows - 1), min(c // ratio, cols - 1)] = True
    return out


def pool_blocks(flags: np.ndarray, ratio: int, grid: tuple[int, int]) -> np.ndarray:
    """Blocks of `ratio` × `ratio` pixels of `flags` that hold any True pixel (bool `grid`)."""
    return _pool(flags, ratio, grid[0], grid[1])


@kernel
def blocks_holding(flags, blocks):
    """Which of the band's blocks hold a True pixel of `flags` (C-contiguous, same grid as
    `blocks`).

    The rows of a run of blocks are OR-ed into one line first (a loop over bytes, which
    vectorises), then each block's BLOCK_PX bytes of it are tested.
    """
    height, width = flags.shape
    source = flags.ravel().view(np.uint8)
    out = np.zeros(blocks.shape, np.bool_)
    line = np.empty(width, np.uint8)
    for br, first, stop in block_runs(blocks):
        c0, c1 = first * BLOCK_PX, min(stop * BLOCK_PX, width)
        n = np.uint64(c1 - c0)
        start = np.uint64(c0)
        for i in range(n):
            line[start + i] = 0
        for r in range(br * BLOCK_PX, min(br * BLOCK_PX + BLOCK_PX, height)):
            at = np.uint64(r * width + c0)
            for i in range(n):
                line[start + i] |= source[at + i]
        for bc in range(first, stop):
            out[br, bc] = line[bc * BLOCK_PX : min(bc * BLOCK_PX + BLOCK_PX, width)].any()
    return out
