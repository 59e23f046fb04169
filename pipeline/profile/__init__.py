"""Profiles and wheel parameters (docs/numbers.md, docs/data-flow.md steps 3d-3f, 5).

`fusion` inner + outer sensor points → the profile frame; `flange` Sh, Sd, qR; `tread`
hollow, flange angle, rim width; `reference` S1002 and LMA; `measurement` the chain of one
wheel and a pass; `window` where a profile can lie in the laser plane; `wheelset`, `rails`,
`conicity` Δr(y) and λe; `wear`, `repeatability` trends and statistics over passes;
`exchange` gauge files in and out.
"""
