"""Decisions read codes, not the project's own messages: rewording a report must not
change which properties are held or which fits count as singular.  A static check of
every module outside ``identify/reporting`` (where text is rendered)."""

import ast
from pathlib import Path

from fem.solver.sensitivity import Verdict, condition_verdict
from fem.specimen import Parameter
from identify.engine.uncertainty import at_limit, parameter_flags

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("fem", "identify", "designer", "studies")


def _modules():
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            if "reporting" not in path.parts:
                yield path, ast.parse(path.read_text(), str(path))


def _text(node) -> bool:
    return isinstance(node, ast.Constant) and isinstance(node.value, str)


def _named(node, suffix: str) -> bool:
    return (isinstance(node, ast.Attribute) and node.attr.endswith(suffix)) or (
        isinstance(node, ast.Name) and node.id.endswith(suffix)
    )


def test_no_verdict_is_compared_with_text():
    """A verdict is compared with ``Verdict`` members, never with its wording."""
    found = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for path, tree in _modules()
        for node in ast.walk(tree)
        if isinstance(node, ast.Compare)
        and any(_named(x, "verdict") for x in [node.left, *node.comparators])
        and any(_text(x) for x in [node.left, *node.comparators])
    ]
    assert found == []


def test_no_flag_is_parsed():
    """Whether a property is at a bound is ``Uncertainty.bounded``, not its flag's text."""
    found = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for path, tree in _modules()
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in ("startswith", "endswith")
        and node.args
        and _text(node.args[0])
        and node.args[0].value.startswith(("at bound", "weakly", "not identifiable", "singular"))
    ]
    assert found == []


def test_the_codes_render_as_before(paper_specimen):
    """The codes print as the words reports and ``--json`` always used, and the at-limit
    code agrees with the flag it replaces in decisions."""
    assert [condition_verdict(c) for c in (10.0, 1e5, 1e8, float("nan"))] == [
        "good",
        "ill-conditioned",
        "singular",
        "singular",
    ]
    assert f"{Verdict.ILL_CONDITIONED:<15s}|" == "ill-conditioned|" and str(Verdict.SINGULAR) == "singular"
    nu12 = Parameter("nu12", "steel")
    steel = paper_specimen.materials["steel"]
    limit = (steel.E1 / steel.E2) ** 0.5
    for value in (0.3, 0.995 * limit):
        flagged = any(f.startswith("at bound") for f in parameter_flags(nu12, value, 0.01, paper_specimen))
        assert at_limit(nu12, value, paper_specimen) == flagged == (value > 0.9 * limit)


#: Names under which the project keeps text meant for people.
MESSAGES = ("w", "warning", "warnings", "message", "note", "notes", "flag", "flags", "reason", "error")


def test_no_message_is_searched_for_a_phrase():
    """No module outside ``identify/reporting`` tests a warning, note, message, flag or
    reason for a phrase (``"..." in w``, ``w.startswith("...")``): what a decision needs
    is a field or a code of the result, so that rewording a message changes no answer."""

    def message(node) -> bool:
        name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else ""
        return name in MESSAGES

    found = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            contains = (
                isinstance(node, ast.Compare)
                and _text(node.left)
                and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops)
                and any(message(c) for c in node.comparators)
            )
            prefixed = (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in ("startswith", "endswith")
                and message(node.func.value)
            )
            if contains or prefixed:
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert found == []
