"""Every --effect kind of ``fit``, on the walk's small plate, ends cleanly (exit 0 or 1:
each applies to it; no traceback, strict JSON); on the peak list, the before/after table follows the peaks
(the baseline and the fit with the effect may match different ones).  A file of its own
so that the suite's workers share the walk."""

import pytest

from fem.effects import REGISTRY
from identify.cli import main as identify_layers

from .walk import check_clean_end, run, strict_json, write_files


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return write_files(tmp_path_factory.mktemp("walk_effects"))


@pytest.mark.parametrize("kind", list(REGISTRY))
def test_fit_effect(files, kind):
    argv = ["fit", files.spec, files.measurements["labelled"], "--effect", kind, "--json"]
    result = run(identify_layers, argv)
    check_clean_end(result, argv, json_out=True)
    assert result.code in (0, 1), result.err[-1500:]  # every kind applies to the walk's plate: no error exit
    data = strict_json(result.out)
    assert data["status"] in ("converged", "poor_fit", "not_converged", "not_identifiable")
    assert (data["status"] == "converged") == (result.code == 0)


def test_point_mass_on_a_peak_list_with_report(files, tmp_path):
    folder = tmp_path / "report"
    argv = [
        "fit",
        files.spec,
        files.measurements["peaks"],
        "--effect",
        "point_mass",
        "--json",
        "--report",
        folder,
    ]
    result = run(identify_layers, argv)
    check_clean_end(result, argv, folder, json_out=True)
    assert result.code in (0, 1)
    before_after = (folder / "before_after.csv").read_text().splitlines()
    assert len(before_after) == 1 + 10  # the header and every peak (8 true, 2 spurious)
