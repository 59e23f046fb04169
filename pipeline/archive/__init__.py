"""The pass archive `wheelscan-pass/1` (docs/formats.md, "Pass archive").

`manifest` parses and writes `manifest.json`; `pass_archive` reads, validates and writes the
zip (frames, optional calibration) with its safety limits.
"""
