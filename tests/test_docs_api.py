"""The Python API reference (docs/api.md) renders numpydoc docstrings whose examples run.

Every object a ``::: module.object`` line lists (and every member its ``members:``
option names) resolves, has a ``Parameters`` section when it takes arguments and an
``Examples`` section, and its doctests pass on their own (no module globals).
"""

import doctest
import importlib
import inspect
import re
from pathlib import Path

import pytest

DOC = Path(__file__).parent.parent / "docs" / "api.md"
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def listed() -> list[str]:
    """The dotted names the reference renders: each ``:::`` object, then its listed members."""
    names: list[str] = []
    current = None
    for line in DOC.read_text(encoding="utf-8").splitlines():
        entry = re.match(r":::\s+(\S+)\s*$", line)
        if entry:
            current = entry.group(1)
            names.append(current)
            continue
        members = re.match(r"\s+members:\s*\[(.*)\]\s*$", line)
        if members and current is not None:
            names += [f"{current}.{m.strip()}" for m in members.group(1).split(",") if m.strip()]
    return names


def resolve(dotted: str):
    """The object of a dotted name: the longest importable module, then attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for name in parts[cut:]:
            obj = getattr(obj, name) if not inspect.isclass(obj) else inspect.getattr_static(obj, name)
        return obj
    raise ImportError(f"{dotted}: no importable module")


def function_of(obj):
    """The function behind a property, or None for a class."""
    if isinstance(obj, property):
        return obj.fget
    return None if inspect.isclass(obj) else obj


def takes_arguments(function) -> bool:
    return any(name not in ("self", "cls") for name in inspect.signature(function).parameters)


def has_section(doc: str, title: str) -> bool:
    return re.search(rf"^{title}\n-{{{len(title)}}}$", doc, re.M) is not None


NAMES = listed()


def test_the_reference_lists_the_api():
    assert "identify.fitting.driver.fit" in NAMES
    assert "identify.engine.result.FitResult.report" in NAMES
    assert len(NAMES) >= 15


@pytest.mark.parametrize("dotted", NAMES)
def test_docstring_is_numpydoc_with_a_passing_example(dotted):
    obj = resolve(dotted)
    function = function_of(obj)
    doc = inspect.cleandoc((function or obj).__doc__ or "")
    assert doc, f"{dotted} has no docstring"
    if function is not None and takes_arguments(function):
        assert has_section(doc, "Parameters"), f"{dotted}: no Parameters section"
    assert has_section(doc, "Examples"), f"{dotted}: no Examples section"

    module = importlib.import_module(inspect.getmodule(function or obj).__name__)
    tests = doctest.DocTestFinder(recurse=False).find(function or obj, dotted, module=module, globs={})
    examples = [t for t in tests if t.examples]
    assert examples, f"{dotted}: no doctest found"
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in examples:
        runner.run(test)
    outcome = runner.summarize(verbose=False)
    assert outcome.failed == 0, f"{dotted}: {outcome.failed} of {outcome.attempted} examples failed"
