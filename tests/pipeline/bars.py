"""Parameters of bar tests: one per (case, metric), expected to fail where a bar is not met."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import pytest


def bar_params(
    names: Iterable[str], metrics: Iterable[str], not_yet: Mapping[tuple[str, str], str]
):
    """pytest params (metric, name), `xfail(strict=True)` with the reason where in `not_yet`.

    Strict: once the method meets the bar the test fails until its entry is removed, so the
    bars in the tests always say what the method reaches.
    """
    return [
        pytest.param(
            metric,
            name,
            id=f"{name}-{metric}",
            marks=[pytest.mark.xfail(strict=True, reason=not_yet[name, metric])]
            if (name, metric) in not_yet
            else [],
        )
        for name in names
        for metric in metrics
    ]
