"""Packaging: the metadata pyproject.toml declares, the bundled samples, what .ci/packaging builds on."""
import importlib.metadata
import inspect
import os
import re
import subprocess
import sys
import tomllib

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.version import Version

from hexatissue import InputError, open_source
from hexatissue.samples import SAMPLE_DATA, SAMPLES, sample_path

from .conftest import ROOT

PACKAGE = ROOT / "hexatissue"


@pytest.fixture(scope="module")
def project():
    path = ROOT / "pyproject.toml"
    if not path.is_file():
        pytest.skip("pyproject.toml is absent (tests run outside the source tree or sdist)")
    return tomllib.loads(path.read_text())["project"]


def _requirements(project, extra=None):
    listed = project["dependencies"] if extra is None else project["optional-dependencies"][extra]
    return {Requirement(r).name: Requirement(r) for r in listed}


def test_licence_is_bsd_3_clause_as_an_spdx_expression_with_its_files(project):
    assert project["license"] == "BSD-3-Clause"  # a string (PEP 639), not the deprecated {text = ...} table
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License") and "the hexatissue developers" in text
    for pattern in project["license-files"]:
        assert list(ROOT.glob(pattern)), pattern
    assert not any(c.startswith("License ::") for c in project["classifiers"])  # PEP 639: the expression only


def test_classifiers_and_urls_say_what_the_hubs_list(project):
    assert "Framework :: napari" in project["classifiers"]  # the napari hub lists only packages with it
    assert any(c.startswith("Topic :: Scientific/Engineering") for c in project["classifiers"])
    assert {"Homepage", "Source", "Issues", "Documentation"} <= set(project["urls"])
    minimum = Version(re.fullmatch(r">=(\d+\.\d+)", project["requires-python"]).group(1))
    versions = [Version(c.split(" :: ")[-1]) for c in project["classifiers"]
                if re.fullmatch(r"Programming Language :: Python :: 3\.\d+", c)]
    assert min(versions) == minimum


def test_requires_python_admits_no_version_a_dependency_cannot_install_on(project):
    """zarr 3 needs Python 3.11: `requires-python = ">=3.10"` let pip pick the wheel on 3.10 and fail there."""
    minimum = re.fullmatch(r">=(\d+\.\d+)", project["requires-python"]).group(1)
    checked = []
    for name in _requirements(project):
        try:  # the installed version: a wheel pip would pick
            meta = importlib.metadata.metadata(name)
        except importlib.metadata.PackageNotFoundError:  # (a development environment with another OpenCV build)
            continue
        needs = meta.get("Requires-Python")
        if needs:
            assert SpecifierSet(needs).contains(minimum), (name, meta["Version"], needs)
            checked.append(name)
    assert "zarr" in checked and "numpy" in checked
    zarr_floor = _requirements(project)["zarr"].specifier
    assert not zarr_floor.contains("2.18.0") and zarr_floor.contains("3.0.0")


def test_opencv_is_the_core_headless_package_and_only_core_cv2_is_used(project):
    cv2 = pytest.importorskip("cv2")
    names = _requirements(project)
    assert "opencv-python-headless" in names and not any("contrib" in n for n in names)
    used = set()
    for path in PACKAGE.rglob("*.py"):
        used |= set(re.findall(r"\bcv2\.(\w+)", path.read_text()))
    assert used  # the rendering and the PNG reader use it
    missing = [n for n in used if not hasattr(cv2, n)]
    modules = [n for n in used if inspect.ismodule(getattr(cv2, n, None))]  # contrib lives in submodules
    assert not missing and not modules, (missing, modules)


def test_dashboard_extra_brings_the_bokeh_distributed_needs(project):
    distributed_versions = pytest.importorskip("distributed.versions")
    bokeh = _requirements(project, "dashboard")["bokeh"]
    floor = next(s.version for s in bokeh.specifier if s.operator == ">=")
    assert distributed_versions.BOKEH_REQUIREMENT.specifier.contains(floor)  # no bokeh the extra allows is refused
    assert "dask" in _requirements(project) and "distributed" in _requirements(project)["dask"].extras


def test_extras_that_are_test_only_are_not_core_dependencies(project):
    core = set(_requirements(project))
    for extra in ("anndata", "validate", "validate-anndata", "dashboard"):
        assert not core & set(_requirements(project, extra)), extra


def test_every_bundled_sample_is_package_data_and_opens(tmp_path):
    assert (SAMPLE_DATA.name, SAMPLE_DATA.parent.name) == ("sample_data", "hexatissue")  # inside the package
    sizes = {"epicure_notum": (11, (160, 257)), "mpf_small": (301, (151, 140))}
    for name in SAMPLES:
        path = sample_path(name)
        assert path.is_relative_to(SAMPLE_DATA) and (path.parent / "README.md").is_file()
        source = open_source(path)
        assert (source.n_frames, source.shape) == sizes[name]
    with pytest.raises(InputError, match=r"^name must be one of \['epicure_notum', 'mpf_small'\]; got 'nope'$"):
        sample_path("nope")
    env = {**os.environ, "PYTHONPATH": str(PACKAGE.parent)}  # the package these tests import, from another folder
    printed = subprocess.run([sys.executable, "-m", "hexatissue.samples", "epicure_notum"], capture_output=True,
                             text=True, check=True, cwd=tmp_path, env=env).stdout.strip()
    assert printed == str(sample_path("epicure_notum"))


def test_the_epicure_sample_has_one_calibration_whichever_way_it_is_opened(tmp_path):
    """open_source (Python), `hexatissue analyze` (metadata.json), a copy of the file, and the napari sample layer's
    scale and units (through the Analyze widget's layer_calibration) all give 0.2 um/px and 300 s per frame: the
    pixel size from the file's ImageJ header, the frame interval (absent from it) from the sample's README."""
    import json
    import shutil

    from hexatissue import Calibration
    from hexatissue.cli import main
    from hexatissue.napari.sample import epicure_labels
    from hexatissue.samples import SAMPLE_CALIBRATION

    want = Calibration(0.2, "um", 300.0, "s")
    assert SAMPLE_CALIBRATION["epicure_notum"] == want
    path = sample_path("epicure_notum")
    source = open_source(path)
    assert source.calibration == want
    assert (source.calibration.length_from, source.calibration.time_from) == ("file", "sample")
    assert source.description["notes"][-1] == ("frame interval 300 s from the bundled sample's documentation (the "
                                               "file's metadata has none)")
    shutil.copy(path, tmp_path / "copy.tif")
    assert open_source(tmp_path / "copy.tif").calibration == want  # the same bytes: the same sample
    assert open_source(path, frame_interval=60).calibration == Calibration(0.2, "um", 60.0, "s")  # a flag wins
    _, kwargs, _ = epicure_labels()[0]
    assert kwargs["scale"] == (300.0, 0.2, 0.2) and kwargs["units"] == ("s", "um", "um")
    widget = pytest.importorskip("hexatissue.napari.widget", exc_type=ImportError)
    assert Calibration.from_dict(widget.layer_calibration(kwargs["scale"], kwargs["units"])) == want
    assert main(["analyze", str(path), "--out", str(tmp_path / "r"), "--workers", "1", "--no-fields", "--no-flow"]) == 0
    recorded = json.loads((tmp_path / "r" / "metadata.json").read_text())["calibration"]
    assert Calibration.from_dict(recorded) == want and recorded["time_from"] == "sample"


def test_the_sdist_manifest_ships_the_tests_and_their_helpers():
    manifest = ROOT / "MANIFEST.in"
    if not manifest.is_file():
        pytest.skip("MANIFEST.in is absent")
    grafted = set(re.findall(r"^graft (\S+)$", manifest.read_text(), re.M))
    assert {"tests", "docs"} <= grafted
    assert (ROOT / "tests" / "__init__.py").is_file() and (ROOT / "tests" / "conftest.py").is_file()
