"""The pass simulator: synthetic stations, wheels and frames with truth (docs/simulator.md).

`station` the simulated station, `wheel` worn profiles, `render`, `frame_render`, `scene` and
`field` the frames (clean and field mode), `passes` whole passes and their archives,
`calibration_images`, `target_images` calibration-board images. Nothing outside tests,
benchmarks and the demo depends on it.
"""
