"""`dentdemo`'s public names: `__all__` lists exactly the lazily imported exports, each one
resolves, `from dentdemo import *` brings them, and type checkers see the same names with their
real types (the TYPE_CHECKING imports in __init__.py)."""

from __future__ import annotations

import ast
from pathlib import Path

import dentdemo

INIT = Path(dentdemo.__file__)


def test_all_lists_every_export_and_each_resolves():
    assert sorted(dentdemo.__all__) == sorted(dentdemo._EXPORTS)
    assert len(set(dentdemo.__all__)) == len(dentdemo.__all__)
    for name in dentdemo.__all__:
        assert getattr(dentdemo, name).__module__ == dentdemo._EXPORTS[name], name


def test_star_import_brings_the_public_names():
    namespace: dict = {}
    exec("from dentdemo import *", namespace)
    assert {k for k in namespace if not k.startswith("__")} == set(dentdemo.__all__)


def test_type_checkers_see_every_export_from_its_module():
    tree = ast.parse(INIT.read_text())
    block = next(
        node
        for node in tree.body
        if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING"
    )
    seen = {
        alias.name: node.module
        for node in block.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert seen == dentdemo._EXPORTS


def test_py_typed_marks_the_package():
    assert (INIT.parent / "py.typed").is_file()
