"""The service on SQLite and on PostgreSQL: one app per database for the test session.

Each test gets fresh tokens; before and after it, every table and the frame store are
emptied (the app's own worker processes write with their own connections, so a rolled-back
transaction cannot isolate these tests the way tests/db does).
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import text

from backend.api.app import create_app
from backend.config import Settings
from backend.services.auth import create_token
from db.models import Base
from tests.databases import BACKENDS, throwaway_database


@pytest.fixture(scope="session", params=BACKENDS)
def service(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[TestClient]:
    data_dir = tmp_path_factory.mktemp(f"service-{request.param}")
    with throwaway_database(request.param, data_dir) as url:
        settings = Settings(
            data_dir=data_dir,
            database_url=url,
            workers=1,
            max_upload_bytes=4 * 1024 * 1024,
            max_frame_bytes=1024 * 1024,
        )
        with TestClient(create_app(settings)) as client:
            yield client
        client.app.state.engine.dispose()


def empty_service(client: TestClient) -> None:
    client.app.state.runner.drain()
    shutil.rmtree(client.app.state.store.root, ignore_errors=True)
    engine = client.app.state.engine
    with engine.begin() as connection:
        if engine.dialect.name == "postgresql":
            names = ", ".join(f'"{t.name}"' for t in Base.metadata.sorted_tables)
            connection.execute(text(f"TRUNCATE {names} RESTART IDENTITY CASCADE"))
        else:
            for table in reversed(Base.metadata.sorted_tables):
                connection.execute(table.delete())


@pytest.fixture
def client(service: TestClient) -> Iterator[TestClient]:
    empty_service(service)
    yield service
    empty_service(service)


def make_tokens(client: TestClient) -> dict[str, str]:
    """A live token per role."""
    made = {}
    with client.app.state.session_factory() as session:
        for role in ("viewer", "operator", "admin"):
            made[role] = create_token(session, role=role, name=f"test {role}")[1]
        session.commit()
    return made


@pytest.fixture
def tokens(client: TestClient) -> dict[str, str]:
    return make_tokens(client)


@pytest.fixture
def auth(tokens: dict[str, str]):
    """auth("operator") → the Authorization header of that role's token."""
    return lambda role: {"Authorization": f"Bearer {tokens[role]}"}
