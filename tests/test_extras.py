"""graphpose._extras: the optional dependencies, imported where used, and the pip command that
installs one for this installation (a checkout's editable install or a wheel)."""

import json

import pytest

import graphpose._extras as extras
from graphpose import InputError
from tests.conftest import REPO


def test_the_install_hint_fits_how_graphpose_was_installed(monkeypatch, tmp_path):
    import graphpose._extras as extras

    assert extras.checkout_root() == REPO  # the tests run from this checkout
    assert extras.install_hint("plot") == f'pip install -e ".[plot]" (in {REPO})'
    monkeypatch.setattr(extras, "checkout_root", lambda: None)  # as from a wheel
    assert extras.install_hint("plot") == 'pip install "graphpose[plot]"'
    monkeypatch.setattr(extras, "install_hint", lambda extra: f"HINT {extra}")
    with pytest.raises(Exception, match="Parquet results needs no_such_module_here .the batch extra.: HINT batch"):
        extras.require("no_such_module_here", "batch", "Parquet results")


# --- paths as given -----------------------------------------------------------------------


def test_require_imports_what_is_installed_and_names_the_missing_one():
    assert extras.require("json", "batch", "anything") is json
    assert extras.require("os.path", "plot", "anything").join("a", "b").endswith("b")
    with pytest.raises(InputError, match=r"^graphpose track --plot needs no_such_pkg \(the plot extra\): pip install"):
        extras.require("no_such_pkg.sub", "plot", "graphpose track --plot")


class _Distribution:
    def __init__(self, text):
        self.text = text

    def read_text(self, name):
        assert name == "direct_url.json"
        return self.text


@pytest.mark.parametrize("text, root", [
    (json.dumps({"url": "file:///work/checkout", "dir_info": {"editable": True}}), "/work/checkout"),
    (json.dumps({"url": "file:///work/checkout", "dir_info": {}}), None),  # a non-editable local install
    (json.dumps({"url": "https://example.org/graphpose.whl", "dir_info": {"editable": True}}), None),
    ("{not json", None),
    (None, None),  # a wheel without direct_url.json
])
def test_an_installed_copy_finds_its_editable_checkout_from_pep_610(monkeypatch, tmp_path, text, root):
    # Imported from a copy outside any checkout, the root comes from direct_url.json alone.
    import importlib.metadata

    monkeypatch.setattr(extras, "__file__", str(tmp_path / "site-packages" / "graphpose" / "_extras.py"))
    monkeypatch.setattr(importlib.metadata, "distribution", lambda name: _Distribution(text))
    found = extras.checkout_root()
    assert found == (None if root is None else extras.Path(root))
