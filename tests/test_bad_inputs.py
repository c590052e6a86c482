"""Slips and bad paths a lab makes: each a one-line error naming the value and
the fix, exit status 2, nothing written; or a documented sound behaviour."""

import copy
import os
import tomllib

import pytest

from fem.errors import SpecError
from fem.laminates.material import Material
from fem.spec import parse_spec
from identify.cli import main
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED

BASE = tomllib.loads(COATED_PLATE.read_text())


def one_line_error(capsys, argv, *fragments):
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and err.count("\n") == 1, err
    for fragment in fragments:
        assert fragment in err, err
    return err


def edited(edit) -> dict:
    data = copy.deepcopy(BASE)
    edit(data)
    return data


@pytest.mark.parametrize(
    "edit,fragments",
    [
        (
            lambda d: d["specimen"]["layers"][1].update(thickness_mm=0.0007),
            ["thickness_mm = 0.0007", "0.7, not 0.0007 m"],
        ),
        (
            lambda d: d["materials"]["brass"].update(nu12=0.9, G12_GPa=100 / 3.8),
            ["nu12 = 0.9", "isotropic", "< 0.5"],
        ),
        (lambda d: d["specimen"]["layers"][1].update(angle_deg=1e300), ["angle_deg = 1e+300", "360"]),
        (
            lambda d: d["materials"].update(spare={**d["materials"]["steel"]}),
            ["[materials.spare]", "no layer uses it"],
        ),
        (lambda d: d.update(model=5), ["[model] = 5", "must be a table"]),
    ],
    ids=["metres typed as mm", "isotropic nu 0.9", "angle 1e300", "identified but unused", "model = 5"],
)
def test_spec_slips(edit, fragments):
    with pytest.raises(SpecError) as info:
        parse_spec(edited(edit))
    assert "\n" not in str(info.value)
    for fragment in fragments:
        assert fragment in str(info.value), str(info.value)


def test_api_moduli_in_gpa_where_pa_are_expected():
    with pytest.raises(SpecError, match="E1 = 200 Pa is below 100000 Pa: a unit slip"):
        Material("steel", 200, 200, 77, 0.3, 7850)


@pytest.mark.parametrize(
    "content,fragment",
    [("[specimen]\nname = 'x'\n".encode("utf-16"), "not UTF-8 text"), (bytes(range(256)), "not UTF-8 text")],
    ids=["UTF-16", "binary"],
)
def test_unreadable_spec_files(tmp_path, capsys, content, fragment):
    spec = tmp_path / "spec.toml"
    spec.write_bytes(content)
    one_line_error(capsys, ["predict", spec], fragment)


def test_measurement_paths_and_rows(tmp_path, capsys):
    """A folder for a CSV, and an unquoted label on the first data row (its comma splits it)."""
    one_line_error(capsys, ["fit", COATED_PLATE, tmp_path], "is a folder")
    bad = tmp_path / "labels.csv"
    bad.write_text("configuration,mode,frequency_hz,std_hz,label\noriginal,1,129.2,0.06,(9,9)\n")
    one_line_error(capsys, ["fit", COATED_PLATE, bad], "line 2 has 6 fields", 'quoted, e.g. "(1,2)"')


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads and writes whatever the permissions say")
def test_unreadable_csv_and_read_only_folder(tmp_path, capsys):
    csv = tmp_path / "data.csv"
    csv.write_text(COATED_PLATE_MEASURED.read_text())
    csv.chmod(0)
    one_line_error(capsys, ["fit", COATED_PLATE, csv], "cannot be read")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    one_line_error(capsys, ["fit", "--report", locked / "report"], "not writable")


@pytest.mark.parametrize("modes", ["0", "1000"])
def test_predict_modes_out_of_range(capsys, modes):
    """--modes is limited like [model] modes: 1 to 60 (1000 would run for minutes)."""
    one_line_error(capsys, ["predict", COATED_PLATE, "--modes", modes], f"--modes = {modes}", "1 to 60")


def test_peaks_out_onto_a_folder(tmp_path, capsys):
    import numpy as np

    from identify.recordings.tap_simulation import Modes, Session, write_csv

    hit = Session(Modes(np.array([150.0]), np.array([0.01]), np.array([1.0])), n_hits=1, seed=1).hits()[0]
    write_csv(hit, tmp_path / "hit.csv")
    one_line_error(capsys, ["peaks", tmp_path / "hit.csv", "--out", tmp_path], "is a folder")
