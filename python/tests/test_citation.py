"""CITATION.cff is valid Citation File Format 1.2.0 and cites the paper.

Debian has no CFF validator (cffconvert is not packaged), so this checks what
the format's schema requires, by hand: the file's own required keys, each
author a person (family-names or given-names) or an entity (name), and the
preferred citation an article with its authors, title, journal, year, volume,
pages and a DOI of the schema's pattern. Each check is also shown to fail when
what it checks is removed, so that it cannot pass by looking at nothing.
"""

import copy
import re

import pytest
import yaml

from conftest import SOURCE_DIR

# The schema's pattern for a DOI (definitions/doi).
DOI = re.compile(r"^10\.\d{4,9}(\.\d+)?/[A-Za-z0-9:/_;\-\.\(\)\[\]\\]+$")
PAPER_DOI = "10.1016/j.triboint.2018.01.018"


def authors_problems(authors, where):
    if not isinstance(authors, list) or not authors:
        return [f"{where}: no authors"]
    problems = []
    for i, a in enumerate(authors):
        if not isinstance(a, dict):
            problems.append(f"{where}[{i}]: not a person or an entity")
        elif not (a.get("family-names") or a.get("given-names") or a.get("name")):
            problems.append(f"{where}[{i}]: neither family-names/given-names nor name")
    return problems


def problems(cff):
    """What keeps `cff` (the parsed file) from being valid CFF 1.2.0 citing the paper."""
    found = []
    if cff.get("cff-version") != "1.2.0":
        found.append("cff-version is not 1.2.0")
    for key in ("message", "title"):
        if not isinstance(cff.get(key), str) or not cff[key].strip():
            found.append(f"no {key}")
    found += authors_problems(cff.get("authors"), "authors")
    paper = cff.get("preferred-citation")
    if not isinstance(paper, dict):
        return found + ["no preferred-citation"]
    if paper.get("type") != "article":
        found.append("preferred-citation: type is not article")
    found += authors_problems(paper.get("authors"), "preferred-citation.authors")
    for key in ("title", "journal"):
        if not isinstance(paper.get(key), str) or not paper[key].strip():
            found.append(f"preferred-citation: no {key}")
    for key in ("year", "volume", "start", "end"):
        if not isinstance(paper.get(key), int) or paper[key] < 1:
            found.append(f"preferred-citation: no {key} (a positive integer)")
    if isinstance(paper.get("start"), int) and isinstance(paper.get("end"), int) \
            and paper["end"] < paper["start"]:
        found.append("preferred-citation: end before start")
    doi = paper.get("doi")
    if not isinstance(doi, str) or not DOI.match(doi):
        found.append(f"preferred-citation: doi {doi!r} is not a DOI (10.NNNN/...)")
    return found


@pytest.fixture(scope="module")
def cff():
    return yaml.safe_load((SOURCE_DIR / "CITATION.cff").read_text())


def test_citation_is_valid_and_cites_the_paper(cff):
    assert problems(cff) == []
    paper = cff["preferred-citation"]
    assert [a["family-names"] for a in paper["authors"]] == ["Braun", "Miyashita", "Fujii", "Persson"]
    assert paper["title"] == "On the load dependence of friction: Role of the long-range elastic coupling"
    assert paper["journal"] == "Tribology International"
    assert (paper["volume"], paper["start"], paper["end"], paper["year"]) == (123, 209, 215, 2018)
    assert paper["doi"] == PAPER_DOI


REMOVABLE = [("cff-version",), ("message",), ("title",), ("authors",),
             ("preferred-citation",), ("preferred-citation", "type"),
             ("preferred-citation", "authors"), ("preferred-citation", "title"),
             ("preferred-citation", "journal"), ("preferred-citation", "year"),
             ("preferred-citation", "volume"), ("preferred-citation", "start"),
             ("preferred-citation", "end"), ("preferred-citation", "doi")]


@pytest.mark.parametrize("path", REMOVABLE, ids=".".join)
def test_a_removed_field_is_found_missing(cff, path):
    broken = copy.deepcopy(cff)
    parent = broken
    for key in path[:-1]:
        parent = parent[key]
    del parent[path[-1]]
    assert problems(broken)


@pytest.mark.parametrize("change", [
    lambda c: c["authors"][0].pop("name"),
    lambda c: c["preferred-citation"]["authors"][0].clear(),
    lambda c: c["preferred-citation"].update(doi="https://doi.org/" + PAPER_DOI),
    lambda c: c["preferred-citation"].update(type="software"),
    lambda c: c["preferred-citation"].update(end=200),
], ids=["author without a name", "paper author without names", "doi as a URL", "not an article",
        "end before start"])
def test_a_wrong_field_is_found(cff, change):
    broken = copy.deepcopy(cff)
    change(broken)
    assert problems(broken)
