"""The service's logic and its transactions (docs/service.md, docs/data-flow.md steps 1-7).

Routes and CLI verbs call these functions; they run the SQL and commit. Ingest and live
streams (`ingest`, `streaming`, `sites`, `pass_wheels`), results, limits and margins
(`results`, `limits`, `margins`; docs/numbers.md), read models (`queries`, `wheel_data`,
`review`, `trends`, `vehicles`), images and the 3D viewer (`images`, `viewer`), reports and
exports (`reports`, `report_pdf`, `report_plot`, `profile_export`, `references`,
`agreement_report`), tokens and audit (`auth`), frame retention (`retention`).
"""
