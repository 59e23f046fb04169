"""wheelscan backend: the FastAPI service, jobs, storage, reports and the `wheelscan` CLI."""
