"""The stored conicity document keeps the reason of a Δr(y) computed over fewer shifts
than searched beside its curve, so the review app can say which amplitudes it lacks."""

from __future__ import annotations

import numpy as np

from backend.services.results import conicity_document
from pipeline.profile.rails import track_rails
from pipeline.profile.reference import load_reference_profile
from pipeline.profile.wheelset import WheelCurve, axle_conicity
from pipeline.simulation.wheel import wheel_profile


def test_a_conicity_over_fewer_shifts_is_stored_with_its_reason() -> None:
    outline = wheel_profile(load_reference_profile("S1002"))
    top = int(np.argmax(outline.z_mm))
    x, z = outline.x_mm[top:], outline.z_mm[top:]
    end = int(np.flatnonzero(np.diff(x) <= 0)[0]) + 1
    x, z = x[:end], z[:end]
    # 24–30 mm beyond the flange top unseen: the rails touch the bridge at |y| > 4.2 mm
    unseen = (x >= x[0] + 24) & (x <= x[0] + 30)
    gapped = WheelCurve(x[~unseen], z[~unseen])
    rails = track_rails()
    whole = conicity_document(axle_conicity(WheelCurve(x, z), WheelCurve(x, z), 1360.0, rails))
    partial = conicity_document(axle_conicity(gapped, gapped, 1360.0, rails))
    assert whole["reason"] is None
    assert partial["reason"].startswith("Δr(y) kept over y = -4.20 to +4.20 mm")
    assert partial["y_mm"][0] == -4.2 and partial["conicity_3mm"] == whole["conicity_3mm"]
    assert partial["conicity"][-1] is None and whole["conicity"][-1] is not None
