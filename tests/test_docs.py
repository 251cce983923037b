"""The docs read the registries: their method tables list exactly the registered methods. Links
between the docs resolve, and the docs speak of ideas, not of the project's history."""

from __future__ import annotations

import re

import pytest

from game.shadows import registry
from game.soft import methods as trace_methods
from tests.helpers import ROOT

DOCS = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])


def table_after(text: str, heading: str) -> list[str]:
    """The first column of the first table after the line that starts with ``heading``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(heading))
    rows, seen = [], False
    for line in lines[start + 1:]:
        if line.startswith("|"):
            seen = True
            cell = line.split("|")[1].strip()
            if not set(cell) <= set("-: "):
                rows.append(cell)
        elif seen:
            break
    return [re.match(r"`([^`]+)`", r).group(1) for r in rows[1:]]  # rows[0] is the header


def test_the_reference_lists_every_registered_method():
    text = (ROOT / "docs" / "reference.md").read_text()
    assert table_after(text, "**Methods**") == list(registry.METHODS)
    assert table_after(text, "**Trace methods**") == list(trace_methods.METHODS)


@pytest.mark.parametrize("doc", DOCS, ids=[str(d.relative_to(ROOT)) for d in DOCS])
def test_links_resolve(doc):
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", doc.read_text()):
        if "://" in target:
            continue
        assert (doc.parent / target).exists(), f"{doc.name}: {target}"


@pytest.mark.parametrize("doc", DOCS, ids=[str(d.relative_to(ROOT)) for d in DOCS])
def test_docs_name_ideas_not_history(doc):
    text = doc.read_text()
    for pattern in (r"\bissue \d", r"\bthe seed\b", r"CONTRACT\.md", r"\bcommit [0-9a-f]{7}"):
        assert not re.search(pattern, text, re.I), f"{doc.name}: {pattern}"
