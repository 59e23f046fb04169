"""The one configuration of the pipeline's compiled (numba) kernels.

Kernels are compiled on first use and cached beside their module, so a worker compiles each
once per installation. They run on the calling thread only (no parallel loops): a frame is
one worker's work, and the service scales with processes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar, cast

import numba

F = TypeVar("F", bound=Callable[..., object])


def kernel(func: F) -> F:
    """Compile `func` with numba: no Python objects, cached, GIL released.

    `error_model="numpy"` makes a division by zero give inf/NaN as NumPy does (no exception
    checks in the loops); `fastmath={"contract"}` only lets a multiply and an add fuse (FMA),
    which changes results in the last bit, never their order of summation.
    """
    compiled = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath={"contract"})
    return cast(F, compiled(func))
