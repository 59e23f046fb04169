"""Operations: backup and restore (docs/service.md, "Retention, backup") and the demo.

`backup`, `restore`, `snapshot` (the `wheelscan-backup/1` archive both use), `demo` (the
simulated pass `make run` serves).
"""
