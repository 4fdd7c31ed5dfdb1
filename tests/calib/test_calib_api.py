"""The package's API: every public name of ``calib`` resolves to the object its module defines, and
importing one module of calib does not load the solvers (a command that only needs the errors stays fast)."""

import importlib
import subprocess
import sys

import pytest

import calib


@pytest.mark.parametrize("name", sorted(calib.API))
def test_every_public_name_is_the_object_its_module_defines(name):
    assert getattr(calib, name) is getattr(importlib.import_module(calib.API[name]), name)
    assert name in dir(calib)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'solver'"):
        calib.solver


def test_importing_the_errors_loads_no_solver():
    # a fresh interpreter: this one has loaded every module already (what the test proves is an import)
    code = "import sys, calib.errors; print(sorted(m for m in sys.modules if m.startswith('calib')))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "['calib', 'calib.errors']"
