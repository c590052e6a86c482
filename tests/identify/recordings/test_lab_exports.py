"""Recordings as labs export them: a time column printed with 7 significant digits, or
no time column and integer ADC counts on an offset, give the peaks of the full-precision
file; a real gap (dropped samples) is refused at its line."""

import re

import numpy as np
import pandas as pd
import pytest

from fem.errors import MeasurementError
from identify.recordings.peaks import extract_peaks
from identify.recordings.readers import read_csv, read_recordings
from identify.recordings.tap_quirks import clipped, with_hum, write_counts_csv, write_rounded_csv
from identify.recordings.tap_simulation import Modes, Session, write_csv

#: The test plate's separated modes at 48 kHz, 2-s hits (a full lab recording).
MODES = Modes(
    [129.2, 191.6, 238.8, 383.0, 590.0], [0.006, 0.005, 0.004, 0.005, 0.003], [1.0, -0.8, 0.6, 1.2, 0.9]
)


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exports")
    hits = Session(MODES, n_hits=3, seed=11).hits()
    files = {"full": [], "rounded": [], "counts": []}
    for hit in hits:
        for kind, write in (
            ("full", write_csv),
            ("rounded", write_rounded_csv),
            ("counts", write_counts_csv),
        ):
            path = folder / f"{kind}_{hit.source}.csv"
            write(hit, path)
            files[kind].append(path)
    return files


def test_rounded_time_and_counts_give_the_full_precision_peaks(exports):
    """Acceptance: frequencies within 0.01 % (the peaks' own scatter is about 0.03 %:
    the same hits must give the same peaks far closer than that)."""
    full = extract_peaks(exports["full"]).table["frequency_hz"].to_numpy()
    rounded = extract_peaks(exports["rounded"]).table["frequency_hz"].to_numpy()
    counts = extract_peaks(exports["counts"], sample_rate=48000.0).table["frequency_hz"].to_numpy()
    assert len(full) == len(MODES.frequencies_hz)
    np.testing.assert_allclose(rounded, full, rtol=1e-4)
    np.testing.assert_allclose(counts, full, rtol=1e-4)


def test_rounded_time_column_reads_the_exact_rate(exports):
    text = exports["rounded"][0].read_text().splitlines()
    assert text[2].startswith("2.083333e-05,") and text[3].startswith("4.166667e-05,")
    assert read_csv(exports["rounded"][0]).sample_rate == 48000.0


def test_counts_need_the_sample_rate(exports):
    with pytest.raises(MeasurementError, match=r"no time_s column and no sample rate; .*--sample-rate"):
        read_csv(exports["counts"][0])
    hit = read_csv(exports["counts"][0], sample_rate=48000)
    assert np.all(hit.force == np.rint(hit.force))  # integer counts
    assert np.median(hit.force) == pytest.approx(1200, abs=5)  # on the ADC's offset, removed downstream (frf)


def _series(n=2000, rate=48000.0):
    t = np.arange(n) / rate
    return pd.DataFrame(
        {"time_s": t, "force": np.exp(-(((t - 1e-3) / 2e-4) ** 2)), "acceleration": np.sin(t * 2000)}
    )


def test_dropped_sample_is_refused_at_its_line(tmp_path):
    """One sample dropped after file line 1001: the step to line 1002 is 2 dt."""
    path = tmp_path / "gap.csv"
    path.write_text(_series().drop(index=1000).to_csv(index=False, float_format="%.7g"))
    with pytest.raises(
        MeasurementError,
        match=r"gap.csv: line 1002: time step 4.167e-05 s differs from the least-squares step",
    ):
        read_csv(path)


def test_jitter_within_printed_precision_and_a_thousandth_of_a_step(tmp_path):
    """Timestamps with 0.4e-3 step of clock jitter are accepted; 1e-2 step is a gap-like error."""
    rng = np.random.default_rng(0)
    frame = _series()
    dt = 1 / 48000
    ok, bad = tmp_path / "ok.csv", tmp_path / "bad.csv"
    ok.write_text(
        frame.assign(time_s=frame["time_s"] + 0.2e-3 * dt * rng.uniform(-1, 1, len(frame))).to_csv(
            index=False
        )
    )
    assert read_csv(ok).sample_rate == 48000.0
    bad.write_text(
        frame.assign(time_s=frame["time_s"] + 1e-2 * dt * rng.uniform(-1, 1, len(frame))).to_csv(index=False)
    )
    with pytest.raises(MeasurementError, match=r"bad.csv: line \d+: time step .* printed precision"):
        read_csv(bad)


def test_time_printed_too_coarsely_is_refused(tmp_path):
    path = tmp_path / "coarse.csv"
    path.write_text(_series().to_csv(index=False, float_format="%.3f"))
    with pytest.raises(
        MeasurementError, match=r"coarse.csv: time_s does not resolve the samples.*--sample-rate"
    ):
        read_csv(path)


@pytest.fixture(scope="module")
def hits():
    return Session(MODES, n_hits=3, seed=11).hits()


def test_mains_hum_is_removed_and_said(hits):
    """50 Hz hum and 4 harmonics, the fundamental at 3 % of the response's peak (a poorly
    grounded sensor): removed, the peaks those of the clean hits within 0.01 %, no mode
    at a harmonic and no peak left there in |H1|, and a note per hit."""
    clean = extract_peaks(hits).table["frequency_hz"].to_numpy()
    result = extract_peaks([with_hum(h, 50.0, 3e-2) for h in hits])
    np.testing.assert_allclose(result.table["frequency_hz"], clean, rtol=1e-4)
    assert sum("mains hum at 50.00 Hz removed" in n for n in result.notes) == 3
    assert not any(re.search(r"\b(50|100)\.0 Hz \(", n) for n in result.notes)


def test_unremoved_hum_stands_in_the_frf(hits, monkeypatch):
    """The same hum with the removal switched off (the test above is not vacuous): 50
    and 100 Hz stand over 20 dB tall in |H1|.  They are not taken for modes (a steady
    sine's pole has a damping ratio of ~1e-5 that changes by more than ``PeakPolicy.damp_tol`` from
    order to order, so it is never stable) but named as spurious peaks."""
    import identify.recordings.frf as frf

    monkeypatch.setattr(frf, "remove_hum", lambda hit: (hit, None))
    result = extract_peaks([with_hum(h, 50.0, 3e-2) for h in hits])
    assert np.min(np.abs(result.table["frequency_hz"].to_numpy() - 50.0)) > 10
    spurious = next(n for n in result.notes if n.startswith("peaks picked on |H1| without a stable pole"))
    tall = {float(f) for f, db in re.findall(r"([\d.]+) Hz \(([\d.]+) dB\)", spurious) if float(db) > 20}
    assert {50.0, 100.0} <= tall, spurious


@pytest.mark.parametrize("channel", ["force", "response"])
def test_clipped_hit_is_rejected_naming_the_channel(hits, channel):
    result = extract_peaks([clipped(hits[0], channel)] + hits[1:])
    assert [r.source for r in result.rejected] == ["hit1"]
    assert result.rejected[0].reason.startswith(f"{channel} clipped: ")
    with pytest.raises(MeasurementError, match=rf"every hit was rejected \(hit1: {channel} clipped"):
        extract_peaks([clipped(h, channel) for h in hits])


def _wav_int(path, hit, bits):
    """A PCM WAV of ``bits`` (16, 24 or 32) written with the standard library, channels
    (force, response) scaled to 2/3 of full scale."""
    import wave

    full = 2 ** (bits - 1) - 1
    data = np.column_stack([x / np.abs(x).max() * full * 2 / 3 for x in (hit.force, hit.response)])
    counts = np.rint(data).astype("<i4")
    raw = counts.view(np.uint8).reshape(-1, 4)[:, : bits // 8].tobytes()  # little-endian: the low bytes
    with wave.open(str(path), "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(bits // 8)
        w.setframerate(48000)
        w.writeframes(raw)


@pytest.mark.parametrize("kind", ["wav16", "wav24", "wav32", "wav_float", "mat", "tdms", "mat_time"])
def test_every_format_gives_the_csv_peaks(tmp_path, hits, kind):
    """WAV 16/24/32-bit PCM and float, MATLAB .mat (with sample_rate or time_s) and NI TDMS:
    the same hits give the full-precision CSV's peaks within 0.01 % (16-bit counts add
    quantisation noise 1e-5 of full scale, far under the hits' own 1e-4 noise)."""
    from nptdms import ChannelObject, TdmsWriter
    from scipy.io import savemat

    from identify.recordings.tap_simulation import write_wav

    paths = []
    for hit in hits:
        path = tmp_path / f"{hit.source}.{kind.split('_')[0].rstrip('0123456789')}"
        if kind.startswith("wav") and kind != "wav_float":
            _wav_int(path, hit, int(kind[3:]))
        elif kind == "wav_float":
            write_wav(hit, path)
        elif kind == "mat":
            savemat(path, {"force": hit.force, "acceleration": hit.response, "sample_rate": 48000.0})
        elif kind == "mat_time":
            savemat(
                path,
                {
                    "force": hit.force,
                    "acceleration": hit.response,
                    "time_s": np.arange(len(hit.force)) / 48000.0,
                },
            )
        else:
            props = {"wf_increment": 1 / 48000.0}
            with TdmsWriter(path) as writer:
                writer.write_segment(
                    [
                        ChannelObject("hit", "force", hit.force, properties=props),
                        ChannelObject("hit", "acceleration", hit.response, properties=props),
                    ]
                )
        paths.append(path)
    reference = extract_peaks(hits).table["frequency_hz"].to_numpy()
    np.testing.assert_allclose(extract_peaks(paths).table["frequency_hz"], reference, rtol=1e-4)


def test_mat_and_tdms_errors_name_the_file_and_the_fix(tmp_path):
    from scipy.io import savemat

    path = tmp_path / "hit.mat"
    savemat(path, {"force": np.ones(300), "acc": np.ones(300)})
    with pytest.raises(
        MeasurementError, match=r"hit.mat: MAT file holds acc, force; need 'force' and exactly one"
    ):
        read_recordings([path])
    savemat(path, {"force": np.ones(300), "response": np.ones(300)})
    with pytest.raises(MeasurementError, match=r"hit.mat: no time_s and no sample rate .*--sample-rate"):
        read_recordings([path])
    junk = tmp_path / "hit.tdms"
    junk.write_bytes(b"not a tdms file" * 20)
    with pytest.raises(MeasurementError, match=r"hit.tdms: cannot read as TDMS"):
        read_recordings([junk])


def _uff58(func_type, data, x, binary, spacing, ordinate, denominator, name):
    import pyuff

    return pyuff.prepare_58(
        binary=binary,
        func_type=func_type,
        id1=name,
        rsp_node=1,
        rsp_dir=3,
        ref_node=1,
        ref_dir=3,
        data=data,
        x=x,
        abscissa_spacing=spacing,
        abscissa_min=float(x[0]),
        abscissa_inc=float(x[1] - x[0]),
        abscissa_spec_data_type=17 if func_type == 1 else 18,
        ordinate_spec_data_type=ordinate,
        orddenom_spec_data_type=denominator,
    )


@pytest.mark.parametrize("spacing", [1, 0])
def test_uff58_variants_give_the_csv_peaks(tmp_path, hits, spacing):
    """Time records (function type 1) in ASCII UFF58 with the abscissa as start and
    increment (spacing 1) or listed point by point (spacing 0, printed with 6 digits):
    the CSV's peaks within 0.01 %.  (Binary UFF58 is read by pyuff, but pyuff 2.4 writes
    an empty file for binary=1, so no binary file is made here.)"""
    binary = 0
    import pyuff

    paths = []
    for hit in hits:
        t = np.arange(len(hit.force)) / hit.sample_rate
        path = tmp_path / f"{hit.source}.uff"
        pyuff.UFF(str(path)).write_sets(
            [
                _uff58(1, hit.force, t, binary, spacing, 13, 0, "force"),
                _uff58(1, hit.response, t, binary, spacing, 12, 0, "acceleration"),
            ],
            mode="overwrite",
        )
        paths.append(path)
    reference = extract_peaks(hits).table["frequency_hz"].to_numpy()
    np.testing.assert_allclose(extract_peaks(paths).table["frequency_hz"], reference, rtol=1e-4)


def test_uff58_uneven_listed_abscissa_is_refused(tmp_path, hits):
    import pyuff

    f = np.arange(400) * 0.5 + 100.0
    f[200:] += 0.25  # a jump of half a line
    path = tmp_path / "frf.uff"
    pyuff.UFF(str(path)).write_sets([_uff58(4, np.ones(400) + 0j, f, 0, 0, 12, 13, "frf")], mode="overwrite")
    with pytest.raises(
        MeasurementError,
        match=r"frf.uff: record 'frf': abscissa_spacing = 0 and the listed abscissa "
        r"is uneven \(line 202: .*\); export the record on evenly spaced",
    ):
        read_recordings([path])
