"""Migrations: the schema goes up, down and up again on both databases and matches the models."""

from __future__ import annotations

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect

from db.engine import downgrade_database, make_engine, upgrade_database
from db.models import Base
from tests.databases import BACKENDS, throwaway_database


@pytest.mark.parametrize("backend", BACKENDS)
def test_upgrade_downgrade_upgrade_leaves_the_schema_of_the_models(backend, tmp_path) -> None:
    with throwaway_database(backend, tmp_path) as url:
        engine = make_engine(url)
        upgrade_database(engine)
        downgrade_database(engine, "base")
        assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
        upgrade_database(engine)
        with engine.connect() as connection:
            differences = compare_metadata(MigrationContext.configure(connection), Base.metadata)
        engine.dispose()
    assert differences == []
