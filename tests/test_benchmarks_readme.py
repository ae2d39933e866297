"""benchmarks/README.md is what benchmarks/make_readme.py generates from the results files."""

import importlib.util
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


def _make_readme():
    spec = importlib.util.spec_from_file_location("make_readme", BENCH / "make_readme.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_readme"] = module  # dataclasses look their module up while the file runs
    spec.loader.exec_module(module)
    return module


def test_readme_is_generated_from_the_results_files():
    make_readme = _make_readme()
    assert (BENCH / "README.md").read_text(encoding="utf-8") == make_readme.render(), (
        "benchmarks/README.md differs from what `python benchmarks/make_readme.py` writes: rerun it"
    )


def test_every_results_file_has_a_row_and_every_row_a_file():
    make_readme = _make_readme()
    named = [e.results for e in make_readme.ENTRIES]
    assert len(named) == len(set(named))
    assert sorted(named) == sorted(p.name for p in BENCH.glob("results_*.md"))


def test_a_figure_missing_from_its_results_file_is_refused(monkeypatch):
    make_readme = _make_readme()
    first = make_readme.ENTRIES[0]
    wrong = make_readme.Entry(first.results, first.what, first.command, "987654.321 s", first.goal, first.met)
    monkeypatch.setattr(make_readme, "ENTRIES", (wrong,) + make_readme.ENTRIES[1:])
    with pytest.raises(ValueError, match="987654.321"):
        make_readme.render()


def test_a_results_file_without_a_row_is_refused(monkeypatch):
    make_readme = _make_readme()
    dropped = make_readme.ENTRIES[0].results
    monkeypatch.setattr(make_readme, "ENTRIES", make_readme.ENTRIES[1:])
    with pytest.raises(ValueError, match=dropped):
        make_readme.render()


def test_date_and_load_are_read_from_the_file(tmp_path, monkeypatch):
    make_readme = _make_readme()
    (tmp_path / "results_x.md").write_text("# x\n\n2031-02-03 04:05 UTC, load before: 06:09:09 up, load average: 2.5\n3.5 s\n")
    monkeypatch.setattr(make_readme, "HERE", tmp_path)
    entry = make_readme.Entry("results_x.md", "x", "`x`", "3.5 s")
    monkeypatch.setattr(make_readme, "ENTRIES", (entry,))
    row = make_readme.render().splitlines()[-1]
    assert "| 2031-02-03 04:05 | 2.5 | [results_x.md](results_x.md) |" in row
