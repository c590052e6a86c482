"""The recording chain on two variants of the corpus (the study runs all of them): integer
ADC counts on an offset without a time column are honest data and give the layers within
3 std; every hit clipped is refused with the reason, not fitted."""

import json

from studies import recording_chain


def test_counts_are_honest_and_clipped_recordings_are_refused(tmp_path):
    chosen = [v for v in recording_chain.VARIANTS if v.name in ("adc_counts", "all_clipped")]
    outcomes, dense = recording_chain.run(tmp_path, chosen, run_diagnosis=False, with_dense_plate=False)
    counts, clipped = outcomes
    assert counts.peaks == "ok" and counts.status == "converged" and counts.rejected == 3  # the double hits
    assert counts.max_z < 3, counts.z
    assert (
        clipped.peaks.startswith("refused: ")
        and "response clipped" in clipped.peaks
        and clipped.status is None
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [v["variant"] for v in summary["variants"]] == ["adc_counts", "all_clipped"]
    assert summary["variants"][1]["max_abs_z"] is None and dense is None
    assert (tmp_path / "adc_counts" / "report.txt").exists() and (tmp_path / "summary.txt").exists()


def test_noisy_recordings_give_honest_std(tmp_path):
    """At 30 and 20 dB SNR the layers are found within 3 std.  At 20 dB two close pairs
    (0.14-0.4 % apart) each give one peak whose hit-to-hit std_hz is 5 std from either
    mode; before the merged-peak term the fit said "converged" with four moduli 3.3-4.4 std
    off.  The fit names each merged peak."""
    chosen = [v for v in recording_chain.VARIANTS if v.name in ("noisy", "very_noisy")]
    outcomes, _ = recording_chain.run(tmp_path, chosen, run_diagnosis=False, with_dense_plate=False)
    for o in outcomes:
        assert o.peaks == "ok" and o.status == "converged", (o.variant, o.peaks, o.status)
        assert o.max_z < 3, (o.variant, o.z)
    report = (tmp_path / "very_noisy" / "report.txt").read_text()
    assert report.count("one peak where model modes") >= 2
