"""The documentation's sources hold together without building the site (no Sphinx needed).

The site itself is built with warnings as errors by the docs job of ``.ci/run`` (``.ci/docs``). These checks
are the part that also matters on GitHub, where the same Markdown pages are read as they are:

- every relative link of the pages and the README reaches a file, and a ``#anchor`` a heading of its page
  (GitHub's anchors: the heading in lower case, punctuation dropped, spaces as hyphens);
- nothing points into the project's shared folder (the docs stand alone);
- the overview of ``docs/api.md`` covers the package's public names (``hexatissue.__all__``), each entry a
  name its module exports (so that autosummary generates its page and the entry links to it), and every
  module of its list is importable.
"""
import importlib
import re
from pathlib import Path

import pytest

import hexatissue

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
pytestmark = pytest.mark.skipif(not (DOCS / "conf.py").is_file(), reason="docs/ is not beside the tests")

FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"\]\(\s*([^)\s]+)(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.M)


def _pages():
    return sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]


def _prose(text):
    """The Markdown without its code: fenced blocks and inline code spans."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def _slug(heading):
    """GitHub's anchor of a heading."""
    text = re.sub(r"[`*]", "", heading).strip().lower()  # code and emphasis marks are not part of the anchor
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(page):
    return {_slug(h) for h in HEADING.findall(FENCE.sub("", page.read_text(encoding="utf-8")))}


def _links(page):
    return [link for link in LINK.findall(_prose(page.read_text(encoding="utf-8")))
            if not re.match(r"^[a-z][a-z0-9+.-]*:", link)]  # http:, https:, mailto: are the link check's


def test_the_slug_is_githubs():
    assert _slug("Shape function: `shape_function(polygons, p=6)`") == "shape-function-shape_functionpolygons-p6"
    assert _slug("Tracking modes (`TrackOptions.mode`, CLI `--track {auto,always,never}`)") == \
        "tracking-modes-trackoptionsmode-cli---track-autoalwaysnever"
    assert _slug("Advection") == "advection"


def test_the_link_finder_finds_links_across_lines_and_skips_code():
    text = "see [a](one.md) and ![b\nc](figures/x.png), `[d](not.md)`\n```\n[e](nor.md)\n```\n"
    assert LINK.findall(_prose(text)) == ["one.md", "figures/x.png"]


@pytest.mark.parametrize("page", _pages(), ids=lambda p: p.name)
def test_relative_links_reach_a_file_and_a_heading(page):
    broken = []
    for link in _links(page):
        path, _, anchor = link.partition("#")
        target = (page.parent / path).resolve() if path else page
        if not target.exists():
            broken.append(f"{link}: no file {target}")
        elif anchor and target.suffix == ".md" and anchor not in _anchors(target):
            broken.append(f"{link}: no heading with the anchor #{anchor} in {target.name}")
    assert not broken, f"{page.name}: " + "; ".join(broken)


def test_the_docs_stand_alone():
    sources = _pages() + sorted((DOCS / "examples").glob("*.py")) + [DOCS / "conf.py"]
    pointing = [p.name for p in sources if "../shared" in p.read_text(encoding="utf-8")]
    assert not pointing, f"{pointing} point into ../shared"


def _api_entries():
    text = (DOCS / "api.md").read_text(encoding="utf-8")
    overview, _, modules = text.partition("\n## Modules\n")
    entries = re.findall(r"^\s+~(hexatissue\.[\w.]+)$", overview, re.M)
    listed = re.findall(r"^\s+(hexatissue\.[\w.]+)$", modules, re.M)
    return entries, listed


def test_the_api_overview_covers_the_public_names():
    entries, listed = _api_entries()
    documented = set()
    for entry in entries:
        module_name, _, name = entry.rpartition(".")
        assert module_name in listed, f"{entry}: its module {module_name} is not in the list of modules"
        module = importlib.import_module(module_name)
        exported = getattr(module, "__all__", None)
        assert exported is not None and name in exported, \
            f"{entry}: {module_name}.__all__ does not export {name}, so it has no page to link to"
        documented.add(id(getattr(module, name)))
    missing = [n for n in hexatissue.__all__ if n != "__version__" and id(getattr(hexatissue, n)) not in documented]
    assert not missing, f"public names without an entry in docs/api.md: {missing}"


def test_the_listed_modules_import_and_say_what_is_public():
    _, listed = _api_entries()
    assert len(listed) == len(set(listed))
    for name in listed:
        module = importlib.import_module(name)
        assert module.__doc__, f"{name} has no docstring (its page would start empty)"
        assert getattr(module, "__all__", None), f"{name} has no __all__: its page would list its imports too"
