"""Measurement jobs: process pool or Celery, leases (docs/service.md, "Jobs").

`tasks.measure_pass_wheel` measures one wheel in one transaction; `runner` the in-process
pool, `celery_runner` the scale-out workers, `leases` and `lost_wheels` who holds a wheel and
what is sent again, `allocator` the measuring processes' memory settings.
"""
