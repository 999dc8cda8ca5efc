"""graphpose._lazy: the one module __getattr__ of the packages that load their names on first use."""

import sys
import types

import pytest

import graphpose
from graphpose._lazy import lazy_getattr


def test_lazy_getattr_loads_a_name_once_and_keeps_it(monkeypatch):
    package = types.ModuleType("graphpose_lazy_probe")
    package.__path__ = []
    monkeypatch.setitem(sys.modules, package.__name__, package)
    loads = []

    def fake_import(name, anchor):
        loads.append((name, anchor))
        return types.SimpleNamespace(value=42)

    monkeypatch.setattr("graphpose._lazy.importlib.import_module", fake_import)
    get = lazy_getattr(package.__name__, {"value": "sub.mod"})
    assert get("value") == 42 and package.value == 42
    assert loads == [(".sub.mod", package.__name__)]
    with pytest.raises(AttributeError, match="module 'graphpose_lazy_probe' has no attribute 'other'"):
        get("other")


def test_the_packages_names_load_through_it():
    import graphpose.batch
    import graphpose.track

    assert graphpose.track.track_frames is sys.modules["graphpose.track.tracker"].track_frames
    assert graphpose.batch.read_results is sys.modules["graphpose.batch.results"].read_results
    assert graphpose.calibrate.Calibration is sys.modules["graphpose.calibrate.result"].Calibration
    assert isinstance(graphpose.calibrate, types.ModuleType)
    for package in (graphpose, graphpose.batch, graphpose.track, graphpose.calibrate):
        with pytest.raises(AttributeError, match=f"module '{package.__name__}' has no attribute 'nothing_here'"):
            package.nothing_here
