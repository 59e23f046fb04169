"""wheelscan backend: the FastAPI service, jobs, storage, reports and the `wheelscan` CLI."""

__version__ = "0.1.0"
"""The software version (pyproject.toml's): in /healthz, the OpenAPI document and reports."""
