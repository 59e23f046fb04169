"""Service settings: `WHEELSCAN_*` environment variables and CLI flags, read alike by every verb.

Precedence: a CLI flag beats the environment, which beats the default. The default runs on
one machine with nothing to install: SQLite and the frame store under ./data.

Every setting: docs/service.md, "Settings".
"""

from __future__ import annotations

import argparse
from functools import lru_cache
from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict

MIB = 1024 * 1024


class Settings(BaseSettings):
    """Everything the service, its workers and the CLI need to know about their environment."""

    model_config = SettingsConfigDict(env_prefix="WHEELSCAN_", frozen=True)

    data_dir: Path = Field(default=Path("data"), description="frame store and SQLite file")
    database_url: str | None = Field(default=None, description="default: SQLite in data_dir")
    broker_url: str | None = Field(default=None, description="Celery broker (scale-out)")
    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=1, le=65535)
    workers: int = Field(default=2, ge=1, description="measurement worker processes")
    max_upload_bytes: int = Field(default=1024 * MIB, ge=1)
    max_frame_bytes: int = Field(default=32 * MIB, ge=1)
    max_archive_members: int = Field(default=20000, ge=1)
    max_uncompressed_bytes: int = Field(default=8192 * MIB, ge=1)
    max_compression_ratio: float = Field(default=200.0, gt=1.0)
    viewer_host: str = Field(default="127.0.0.1", description="viser 3D viewer interface")
    viewer_port: int = Field(default=8081, ge=1, le=65535, description="viser 3D viewer port")
    frame_retention_days: float | None = Field(
        default=None,
        gt=0,
        description="remove raw frames of passes started longer ago (results are kept); "
        "default: keep forever",
    )
    retention_sweep_interval_s: float = Field(
        default=3600.0, gt=0, description="how often the server applies frame retention"
    )
    frontend_dir: Path = Field(default=Path(__file__).resolve().parent.parent / "frontend")

    # Scale-out (Celery) timing, read by the service and by every worker.
    broker_visibility_timeout_s: float = Field(
        default=600.0,
        gt=0,
        description="a message unacknowledged this long (its worker died) is delivered again",
    )
    broker_restore_interval_s: float = Field(
        default=10.0, gt=0, description="how often workers look for such messages"
    )
    lease_retry_s: float = Field(
        default=5.0, gt=0, description="delay before re-checking a wheel a live worker holds"
    )
    sweep_interval_s: float = Field(
        default=30.0, gt=0, description="how often the service looks for lost messages"
    )
    retry_backoff_max_s: int = Field(default=60, ge=1, description="longest retry delay")
    max_retries: int = Field(default=10, ge=0, description="retries of a transient fault")

    # A worker without the shared frame store reads it over HTTP (backend.storage.remote).
    store_url: str | None = Field(default=None, description="the API's base URL for blobs")
    store_token: str | None = Field(default=None, description="operator token for store_url")
    store_timeout_s: float = Field(default=60.0, gt=0, description="per blob request")

    token: str | None = Field(default=None, description="the station agent's operator token")

    @property
    def resolved_database_url(self) -> str:
        """The database URL, defaulting to a SQLite file in the data folder."""
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'wheelscan.db').resolve()}"

    @property
    def frames_dir(self) -> Path:
        """Content-addressed frame and artefact store."""
        return self.data_dir / "store"


@lru_cache(maxsize=1)
def get_settings() -> Settings:
    """The settings of this process, built once from the environment."""
    return Settings()


def add_settings_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the flags that override `WHEELSCAN_*` variables (shared by every verb)."""
    parser.add_argument(
        "--data", dest="data_dir", type=Path, help="data folder (WHEELSCAN_DATA_DIR)"
    )
    parser.add_argument(
        "--database-url", help="SQLAlchemy URL (WHEELSCAN_DATABASE_URL); default SQLite in --data"
    )
    parser.add_argument("--broker-url", help="Celery broker URL (WHEELSCAN_BROKER_URL)")


def settings_from_args(args: argparse.Namespace) -> Settings:
    """Settings from the environment, overridden by the flags given on the command line."""
    overrides = {
        name: getattr(args, name)
        for name in ("data_dir", "database_url", "broker_url", "host", "port", "workers")
        if getattr(args, name, None) is not None
    }
    return Settings(**overrides)
