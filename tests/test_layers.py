"""The layer boundaries (docs/data-flow.md, docs/style.md §1), checked by parsing imports."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

FORBIDDEN = {
    "pipeline": {
        "backend",
        "db",
        "fastapi",
        "sqlalchemy",
        "alembic",
        "pydantic",
        "viser",
        "celery",
    },
    "db": {"backend", "pipeline", "fastapi", "viser"},
}


def imported_top_modules(path: Path) -> set[str]:
    """Top-level module names imported by one source file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_does_not_import_forbidden_layers(package: str) -> None:
    offenders = []
    for path in sorted((ROOT / package).rglob("*.py")):
        bad = imported_top_modules(path) & FORBIDDEN[package]
        if bad:
            offenders.append(f"{path.relative_to(ROOT)} imports {sorted(bad)}")
    assert offenders == []


def test_only_backend_imports_fastapi_and_viser() -> None:
    offenders = []
    for package in ("pipeline", "db"):
        for path in sorted((ROOT / package).rglob("*.py")):
            if imported_top_modules(path) & {"fastapi", "viser"}:
                offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []


SESSION_CALLS = {"execute", "scalar", "scalars", "get", "add", "delete", "flush", "commit"}
"""Session methods that query or write: a route calls services, which own them."""


def test_routes_leave_queries_and_transactions_to_services() -> None:
    # docs/service.md, "Layers": a route validates, calls one service function, returns a
    # schema; the services run the SQL and commit.
    offenders = []
    for path in sorted((ROOT / "backend" / "api" / "routes").glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == (
                "sqlalchemy"
            ):
                sql = [a.name for a in node.names if a.name not in {"Session", "sessionmaker"}]
                if sql:
                    offenders.append(f"{path.name}:{node.lineno} imports {sql} from sqlalchemy")
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in SESSION_CALLS
                and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "session"
            ):
                offenders.append(f"{path.name}:{node.lineno} session.{node.func.attr}()")
    assert offenders == []


PIPELINE_ORDER = ("extraction", "calibration", "archive", "profile", "simulation")
"""The data flow's order (docs/data-flow.md): a subpackage imports only those before it and
the shared modules at the top of `pipeline/` (errors, imaging, jit, version)."""


def _imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names = {alias.name for n in ast.walk(tree) if isinstance(n, ast.Import) for alias in n.names}
    names |= {
        n.module
        for n in ast.walk(tree)
        if isinstance(n, ast.ImportFrom) and n.module and not n.level
    }
    return names


def test_pipeline_subpackages_import_only_upstream_steps() -> None:
    offenders = []
    for i, package in enumerate(PIPELINE_ORDER):
        downstream = {f"pipeline.{later}" for later in PIPELINE_ORDER[i + 1 :]}
        for path in sorted((ROOT / "pipeline" / package).rglob("*.py")):
            for module in _imported_modules(path):
                if any(module == d or module.startswith(d + ".") for d in downstream):
                    offenders.append(f"{path.relative_to(ROOT)} imports {module}")
    assert offenders == []


def test_services_take_from_the_api_layer_only_its_schemas() -> None:
    offenders = [
        f"{path.relative_to(ROOT)} imports {module}"
        for path in sorted((ROOT / "backend" / "services").rglob("*.py"))
        for module in _imported_modules(path)
        if module.startswith("backend.api") and module != "backend.api.schemas"
    ]
    assert offenders == []
