"""identify-layers predict: table and JSON contract (docs/json.md)."""

import json

import numpy as np

from identify.cli import main
from tests.conftest import DATA, FREE_PLATES


def test_predict_json_shape_and_values(capsys):
    """The example spec with Table 1 values: the JSON has the documented shape and
    the original plate's frequencies are the converged CLT ones (0.02 %)."""
    spec = DATA / "paper_plate_table1.toml"
    assert main(["predict", str(spec), "--json", "--modes", "8"]) == 0
    out = json.loads(capsys.readouterr().out)
    names = [c["name"] for c in out["configurations"]]
    assert names == ["original", "brass_bottom", "brass_top"]
    f = out["configurations"][0]["frequencies_hz"]
    assert len(f) == 8
    np.testing.assert_allclose(
        f, FREE_PLATES["paper_plate_clt_converged"]["first15_elastic_hz"][:8], rtol=2e-4
    )


def test_predict_default_example_table(capsys):
    assert main(["predict"]) == 0
    out = capsys.readouterr().out
    assert "brass_bottom" in out and "Hz" in out


def test_bad_spec_exits_2_with_one_line(capsys, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        "[specimen]\nlength_mm = 150\nwidth_mm = 150\nlayers = "
        "[]\n[materials.x]\nE1_GPa=1\nE2_GPa=1\nG12_GPa=1\nnu12=0.3\ndensity_kg_m3=1000\n"
    )
    assert main(["predict", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "layers is empty" in err and "\n" not in err
