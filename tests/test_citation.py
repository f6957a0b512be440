"""CITATION.cff: researchers cite software; the file must parse and agree with the package's metadata."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_citation_cff_has_the_required_keys_and_the_packages_version_and_licence():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    # the keys Citation File Format 1.2.0 requires
    assert cff["cff-version"] == "1.2.0"
    assert cff["message"] and cff["title"] and cff["authors"]
    assert str(cff["version"]) == project["version"] and cff["license"] == project["license"]
    assert (ROOT / "LICENSE").read_text().startswith("BSD 3-Clause License")
    for ref in cff.get("references", []):  # each cited work has authors, a title, a year and a well-formed DOI
        assert ref["authors"] and ref["title"] and ref["year"], ref
        assert re.fullmatch(r"10\.\d{4,9}/\S+", ref["doi"]), ref["doi"]
