"""The accuracy and speed page is `make bench`'s output: every benchmark module runs in
`python -m benchmarks`, and the committed page has a section from each."""

from pathlib import Path

from benchmarks.__main__ import PAGE, SECTIONS

BENCHMARKS = Path(__file__).parent.parent / "benchmarks"


def test_every_benchmark_module_writes_a_section():
    modules = {p.stem for p in BENCHMARKS.glob("*.py")} - {"__init__", "__main__", "common"}
    assert {module.__name__.split(".")[-1] for _, module in SECTIONS} == modules


def test_the_committed_page_has_every_section():
    text = PAGE.read_text()
    assert "Written by `make bench`" in text
    for heading, _ in SECTIONS:
        assert f"## {heading}\n\n```\n" in text, (
            f"docs/generated/benchmarks.md lacks '{heading}': run make bench"
        )
