"""Calibration: pixels ↔ millimetres (docs/formats.md "Calibration", docs/coordinate-frames.md).

`model` the `wheelscan-calibration/1` file and `StationCalibration`; `camera` intrinsics,
laser plane and camera-to-track from board images (`board` the target's model,
`image_sets` reading a set and calibrating a station from it); `geometry` pixels ↔ track
frame; `search_region` where a wheel's stripe can lie in a frame.
"""
