"""Stripe-centre extraction: frame → `Centres` (docs/extraction.md, docs/data-flow.md step 3b).

`centres.extract_centres` is the entry. The adaptive analysis runs on the blocks of a band
(`band_analysis`, `band`, `blocks`; kernels `band_filters`, `band_segmentation`, `components`,
`closing`); the whole frame is the band of all blocks. Scales and the Hessian
(`gaussian`, `scalespace`, `hessian`, `ridges`), the mask (`segmentation`, `classic` for the
baseline), σB and hints (`adaptive`), the sub-pixel step (`steger`, `normal_fit`,
`normal_equations`, `asymmetry`), the line test (`line_test`), linking, curvature bias and
widths (`linking`, `curvature`, `widths`).
"""
