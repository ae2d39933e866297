"""docs/architecture.md says what the code has: its stage table is ``STAGES``, its spine block the options classes.

The table's rows are the list's entries in the list's order, each with its
options class (and stage keyword where the class first appears), whether it
runs per frame or per movie, and every table or column it reads and writes;
the spine block names every options class and every keyword of ``analyze``.
"""
import ast
import inspect
import re
from pathlib import Path

import pytest

import hexatissue
from hexatissue import analyze, schema
from hexatissue import stages as S
from hexatissue.options import OPTION_CLASSES

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
pytestmark = pytest.mark.skipif(not DOC.is_file(), reason="docs/ is not beside the tests")
NOT_TABLES = ("labels", "polygons", "image", "height")  # what the frame stages hand on besides the tables
PACKAGE = Path(hexatissue.__file__).resolve().parent
#: The stage floor's modules that compute a stage (the models and tissue generators beside them are not stages).
STAGE_PACKAGES = ("mesh", "intensity", "surface", "order", "defects", "mechanics", "track", "flow", "events", "deformation")


def _section(title):
    text = DOC.read_text(encoding="utf-8")
    start = text.index(f"\n## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else len(text)]


def _stage_rows():
    lines = _section("The stage list").splitlines()
    header = lines.index("| stage | options | per | reads | writes |")
    rows = []
    for line in lines[header + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split(" | ")])
    return rows


def _names(cell):
    """The tables and columns a cell names in backticks, ``a.b_re/_im`` read as ``a.b_re`` and ``a.b_im``."""
    out = set()
    for token in re.findall(r"`([^`]+)`", cell):
        first, *more = token.split("/")
        table, _, column = first.partition(".")
        if table not in schema.TABLES:
            continue  # a flag or a summary key
        out.add(first)
        stem = column.rsplit("_", 1)[0] if "_" in column else column
        out |= {f"{table}.{stem}{suffix}" for suffix in more}
    return out


def test_the_names_of_a_cell_are_read_with_their_abbreviations():
    assert _names("`cells.stress_xx/_xy/_yy`, `edges.tension/_sd`, `--intensity`, `grid`") == {
        "cells.stress_xx", "cells.stress_xy", "cells.stress_yy", "edges.tension", "edges.tension_sd", "grid"}


def test_the_stage_table_is_the_stage_list_in_its_order():
    rows = _stage_rows()
    assert [row[0] for row in rows] == [s.name for s in S.STAGES]
    seen = set()
    for row, stage in zip(rows, S.STAGES):
        name, options, per, reads, writes = row
        cls = stage.options
        assert f"`{cls.__name__}`" in options, name
        if cls not in seen:  # the keyword is given where the class first appears
            assert f"(`{cls.stage}`)" in options, name
        seen.add(cls)
        assert ("when" in options) == (stage.enabled is not None or stage.image), name
        assert per.split()[0] == stage.per, name
        # reads: every table the stage reads, and no other
        read_tables = {r for r in stage.reads if r.partition(".")[0] not in NOT_TABLES}
        assert {n.partition(".")[0] for n in _names(reads)} == {r.partition(".")[0] for r in read_tables}, name
        for other in NOT_TABLES:
            if other in stage.reads:
                assert other in reads, (name, other)
        # writes: every table and column, and beyond them only columns of a table the stage writes
        written = {w for w in stage.writes if w.partition(".")[0] not in NOT_TABLES}
        documented = _names(writes)
        assert written <= documented, (name, written - documented)
        for extra in documented - written:
            assert extra.partition(".")[0] in written, (name, extra)
        for other in ("labels", "polygons"):
            assert (other in stage.writes) == (other in writes), (name, other)


def test_the_spine_block_names_every_options_class_and_keyword_in_run_order():
    block = _section("The spine").split("```")[1]
    call = block[block.index("analyze("):]
    call = call[:call.index(")")]
    before = block[:block.index("analyze(")]
    keys = list(dict.fromkeys(s.options.stage for s in S.STAGES))
    assert sorted(keys) == sorted(OPTION_CLASSES)
    assert re.findall(r"\b(\w+Options)\b", before) == [OPTION_CLASSES[k].__name__ for k in keys]
    spine = [p.name for p in inspect.signature(analyze).parameters.values()
             if p.kind is inspect.Parameter.KEYWORD_ONLY]
    assert re.findall(r"(\w+)=", call) == spine + keys


def test_the_module_map_lists_every_options_class():
    row = next(line for line in _section("Module map").splitlines() if "`options.py`" in line)
    assert set(re.findall(r"`(\w+Options)`", row)) == {cls.__name__ for cls in OPTION_CLASSES.values()}


def _imported(module):
    """The hexatissue modules that ``module``'s source imports, at its top and inside functions (read, not run).

    ``from .x import y`` counts as importing ``x`` and ``x.y`` (``y`` may be a module).
    """
    parts = module.split(".")
    path = PACKAGE.joinpath(*parts[1:])
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    package = parts if path.name == "__init__.py" else parts[:-1]
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = ".".join((package[:len(package) - node.level + 1] if node.level else [])
                            + ([node.module] if node.module else []))
            names |= {base} | {f"{base}.{alias.name}" for alias in node.names}
    return {name for name in names if name.split(".")[0] == "hexatissue"}


def _stage_imports(module):
    return sorted(name for name in _imported(module) if name.split(".")[1:2] and name.split(".")[1] in STAGE_PACKAGES)


def test_the_import_reader_sees_relative_imports_and_imports_inside_functions():
    assert {"hexatissue.flow", "hexatissue.flow.piv", "hexatissue.views", "hexatissue.views.layerdata",
            "hexatissue.views.LayerMaker"} <= _imported("hexatissue.views.flow")
    assert "hexatissue.source" in _imported("hexatissue.napari.layers")  # imported inside a function
    assert "hexatissue.analysis.plots" in _imported("hexatissue.analysis")  # a package's __init__.py
    assert "hexatissue.flow.reliable_bins" in _stage_imports("hexatissue.views.flow")


@pytest.mark.parametrize("module", ["hexatissue.plot", "hexatissue.analysis.plots", "hexatissue.workflows.report",
                                    "hexatissue.workflows.figures", "hexatissue.napari.layers",
                                    "hexatissue.napari.widget"])
def test_the_figures_the_report_and_the_napari_layers_import_no_stage_package(module):
    """They take every stage's presentation from its views module (the stage list names it) and the paper's
    figures from ``analysis.plots``; a stage's figure lives in its views module, beside its report section."""
    assert _stage_imports(module) == []
