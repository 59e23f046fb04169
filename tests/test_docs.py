"""The design lives in the repository: every package's docstring points to its docs/ page,
and no source file cites a document the repository does not hold."""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("pipeline", "backend", "db", "benchmarks", "scripts")
CITED = re.compile(r"(?<![\w/.-])((?:[\w.-]+/)*[\w-]+\.md)\b")
"""A cited document: any path ending in .md (docs/numbers.md, BENCHMARKS.md, data/X.md)."""

PACKAGES = sorted(
    path.parent.relative_to(ROOT).as_posix()
    for source in ("pipeline", "backend")
    for path in (ROOT / source).glob("*/__init__.py")
)


def _cited(path: Path) -> set[str]:
    """Documents cited in a source file's strings (docstrings; adjacent literals joined) and
    comments."""
    source = path.read_text(encoding="utf-8")
    texts = [
        node.value
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Constant) and isinstance(node.value, str)
    ]
    texts += [
        token.string
        for token in tokenize.generate_tokens(io.StringIO(source).readline)
        if token.type == tokenize.COMMENT
    ]
    return {document for text in texts for document in CITED.findall(text)}


def _exists(document: str, cited_in: Path) -> bool:
    # a path from the root, from the citing file's folder, or a page of docs/
    return any((base / document).is_file() for base in (ROOT, cited_in.parent, ROOT / "docs"))


def test_every_cited_document_is_in_the_repository() -> None:
    missing = [
        f"{path.relative_to(ROOT)} cites {document}"
        for source in SOURCES
        for path in sorted((ROOT / source).rglob("*.py"))
        for document in sorted(_cited(path))
        if not _exists(document, path)
    ]
    assert missing == []


@pytest.mark.parametrize("package", PACKAGES)
def test_the_package_docstring_points_to_its_docs_page(package: str) -> None:
    tree = ast.parse((ROOT / package / "__init__.py").read_text(encoding="utf-8"))
    docstring = ast.get_docstring(tree) or ""
    pages = [page for page in CITED.findall(docstring) if page.startswith("docs/")]
    assert pages, f"{package}/__init__.py: no docs/ page in its docstring"
    assert all((ROOT / page).is_file() for page in pages), pages


CODE_REFERENCE = re.compile(
    r"`((?:pipeline|backend|db|frontend|scripts|benchmarks)/[\w/.-]+\.(?:py|js)) : ([^`]+)`"
)
"""A docs/ reference to code: `path/module.py : name` or `… : name, other → third`."""


def _defines(source: str, name: str) -> bool:
    definition = rf"(def|class|function|const)\s+{name}\b|^\s*(export\s+)?{name}\s*[:=]"
    return re.search(definition, source, re.MULTILINE) is not None


def test_every_function_and_constant_the_docs_name_exists() -> None:
    # "Where does this number come from" in one hop only helps if the hop lands.
    missing = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        for path, names in CODE_REFERENCE.findall(page.read_text(encoding="utf-8")):
            if not (ROOT / path).is_file():
                missing.append(f"{page.name}: {path}")
                continue
            source = (ROOT / path).read_text(encoding="utf-8")
            for name in re.split(r"[\s,→]+", names):
                name = name.split("(")[0].split(".")[-1]
                if re.fullmatch(r"\w+", name) and not _defines(source, name):
                    missing.append(f"{page.name}: {path} : {name}")
    assert missing == []
