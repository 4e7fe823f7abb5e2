"""The examples in trackcore's docstrings, run as doctests.

Every module of trackcore is searched for ``>>>`` examples (:mod:`doctest`, with ``ELLIPSIS``
and ``NORMALIZE_WHITESPACE``); a failing example fails its module's test.  The examples print
rounded numbers, so their output does not depend on the machine.

Every public function and class of every module (every callable in its ``__all__``;
constants have no docstring of their own) has an example:
:func:`test_every_public_name_has_an_example` keeps it that way for new modules too
(:func:`missing_examples` lists what a module lacks).
"""
from __future__ import annotations

import doctest
import importlib
import inspect
import pkgutil

import numpy as np
import pytest

import trackcore

FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def all_modules() -> list[str]:
    """Every importable module of trackcore (the command-line entry point excepted)."""
    names = ["trackcore"]
    for info in pkgutil.walk_packages(trackcore.__path__, "trackcore."):
        if info.name.endswith("__main__"):
            continue
        names.append(info.name)
    return sorted(names)


def missing_examples(module_name: str) -> list[str]:
    """The public callables of ``module_name`` (its ``__all__``) whose docstring has no ``>>>``."""
    module = importlib.import_module(module_name)
    missing = []
    for name in getattr(module, "__all__", ()):
        obj = getattr(module, name)
        if not callable(obj) or inspect.ismodule(obj):
            continue
        home = getattr(obj, "__module__", None) or module_name
        if home != module_name and name in getattr(importlib.import_module(home), "__all__", ()):
            continue  # re-exported here; counted in the module that defines and exports it
        if ">>>" not in (inspect.getdoc(obj) or ""):
            missing.append(name)
    return missing


@pytest.mark.parametrize("module_name", all_modules())
def test_docstring_examples_pass(module_name):
    module = importlib.import_module(module_name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    with np.printoptions(precision=4, suppress=True, legacy=False):
        for test in finder.find(module, module_name):
            runner.run(test)
    failed, attempted = runner.summarize(verbose=False)
    assert failed == 0, f"{module_name}: {failed} of {attempted} doctest examples failed (see the output above)"


@pytest.mark.parametrize("module_name", all_modules())
def test_every_public_name_has_an_example(module_name):
    missing = missing_examples(module_name)
    assert not missing, f"{module_name}: public names without a '>>>' example: {missing}"


def test_every_public_module_is_on_an_api_page():
    """A module with a public ``__all__`` (not a package, not private) has an automodule."""
    from pathlib import Path

    pages = Path(__file__).resolve().parents[1] / "book" / "appendix" / "api"
    text = "\n".join(p.read_text() for p in sorted(pages.glob("*.md")))
    missing = [
        m for m in all_modules()
        if not any(part.startswith("_") for part in m.split("."))
        and not hasattr(importlib.import_module(m), "__path__")
        and getattr(importlib.import_module(m), "__all__", None)
        and f".. automodule:: {m}\n" not in text
    ]
    assert not missing, f"public modules missing from book/appendix/api/*.md: {missing}"


if __name__ == "__main__":  # counts of what is left: python tests/test_doctests.py
    total = 0
    for name in all_modules():
        left = missing_examples(name)
        total += len(left)
        if left:
            print(f"{name:45s} {len(left):3d}")
    print(f"public callables without an example: {total}")
