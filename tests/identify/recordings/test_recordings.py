"""Recordings: the tap simulator is exact, the writers and readers round-trip CSV, WAV and
UFF58, and every bad input is a one-line MeasurementError naming the file and the fix."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import signal

from fem.errors import MeasurementError
from identify.recordings.frf import average_hits
from identify.recordings.peaks import extract_peaks
from identify.recordings.readers import (
    Hit,
    MeasuredFRF,
    read_csv,
    read_recordings,
    read_uff,
    read_wav,
)
from identify.recordings.tap_simulation import (
    Modes,
    Session,
    TapOptions,
    exact_response,
    hammer_force,
    write_csv,
    write_uff,
    write_wav,
)

#: Modes above 190 Hz with damping >= 0.4 % decay below 1e-2 within 1 s, so 1-s records
#: (quick to write as CSV) need no exponential window.
MODES = Modes([191.6, 238.8, 383.0, 590.0], [0.005, 0.004, 0.005, 0.003], [-0.8, 0.6, 1.2, 0.9])
SHORT = TapOptions(duration_s=1.0)


@pytest.fixture(scope="module")
def hits():
    return Session(MODES, n_hits=3, seed=7, options=SHORT).hits()


def test_simulated_response_is_exact():
    """The first-order-hold recursion equals scipy's lsim (linear interpolation of the
    force, state-space integration) to 1e-9 of the peak: exact to rounding."""
    options = TapOptions(duration_s=0.05)
    force = hammer_force(options)
    t = np.arange(len(force)) / options.sample_rate
    ours = exact_response(MODES, force, options.sample_rate)
    w = 2 * np.pi * MODES.frequencies_hz
    reference = sum(
        signal.lsim(([a, 0, 0], [1, 2 * z * wr, wr**2]), force, t)[1]
        for a, z, wr in zip(MODES.residues, MODES.damping_ratios, w)
    )
    assert np.abs(ours - reference).max() < 1e-9 * np.abs(reference).max()


def test_noise_free_frf_is_the_accelerance():
    """Y/X of a noise-free hit is the modal model's accelerance within 1e-3 near every
    peak: the sampled (first-order hold) FRF differs from H(i w) by (w dt)^2/12 < 2e-4."""
    hit = Session(MODES, n_hits=1, options=TapOptions(noise_rel=0.0, jitter_rel=0.0)).hits()[0]
    f = np.fft.rfftfreq(len(hit.force), 1 / hit.sample_rate)
    h = np.fft.rfft(hit.response) / np.fft.rfft(hit.force)
    lines = np.concatenate([np.flatnonzero(np.abs(f - fr) < 3) for fr in MODES.frequencies_hz])
    exact = MODES.accelerance(f[lines])
    assert np.abs(h[lines] / exact - 1).max() < 1e-3


def test_double_hit_and_short_record_are_simulated():
    hit = Session(MODES, n_hits=1, double_hits=(0,), cut_short={0: 0.3}).hits()[0]
    assert hit.duration_s == pytest.approx(0.3)
    above = np.abs(hit.force) > 0.3 * np.abs(hit.force).max()
    assert np.count_nonzero(np.diff(above.astype(int)) == 1) == 2  # two pulses


@pytest.mark.parametrize("kind", ["csv", "csv_rate", "wav", "uff"])
def test_round_trip_gives_the_same_peaks(tmp_path, hits, kind):
    """Files written and read back give the in-memory hits' peaks: CSV keeps 10 digits,
    float32 WAV 7 (so 1e-5 Hz), UFF58 ASCII 13 (the time step 6: the rate is snapped
    to the whole Hz)."""
    paths = []
    for hit in hits:
        path = tmp_path / f"{hit.source}.{kind[:3]}"
        if kind == "csv":
            write_csv(hit, path)
        elif kind == "csv_rate":
            write_csv(hit, path, time_column=False)
        elif kind == "wav":
            write_wav(hit, path)
        else:
            write_uff(path, hit=hit)
        paths.append(path)
    read = read_recordings(paths, sample_rate=48000.0 if kind == "csv_rate" else None)
    assert all(r.sample_rate == 48000.0 and r.force is not None for r in read)
    expected = extract_peaks(hits).table["frequency_hz"].to_numpy()
    got = (
        extract_peaks(paths, sample_rate=48000.0 if kind == "csv_rate" else None)
        .table["frequency_hz"]
        .to_numpy()
    )
    assert len(expected) == 4
    np.testing.assert_allclose(got, expected, atol=1e-5)


def test_wav_response_only_fits_poles_and_says_so(tmp_path, hits):
    """A one-channel WAV: poles fitted to the response spectrum (the hammer's force is
    flat over the band) find exactly the four modes, their frequencies as close as with the
    force channel (0.1 %: the hits' jitter is 3e-4) and their damping within 10 % (the
    force pulse's spectrum falls a little over a mode's bandwidth)."""
    paths = [tmp_path / f"{h.source}.wav" for h in hits]
    for hit, path in zip(hits, paths):
        write_wav(hit, path, force_channel=False)
    assert read_wav(paths[0]).force is None
    result = extract_peaks(paths)
    assert any("no force channel" in n for n in result.notes)
    assert set(result.table["quality"]) == {"response_only"}
    np.testing.assert_allclose(result.table["frequency_hz"], MODES.frequencies_hz, rtol=1e-3)
    np.testing.assert_allclose(result.table["damping_ratio"], MODES.damping_ratios, rtol=0.1)


def test_noisy_one_channel_wav_of_a_real_like_plate_gives_its_modes_only(tmp_path):
    """The campaign's one-channel WAV gave 91 "modes" with exit 0; a real-like plate
    (36 modes in 60-1900 Hz, damping 0.3-1.1 %) hit once at 40 dB SNR with mains hum
    gave 114 by peak picking.  The pole route finds only true modes (each within 0.5 % of
    one: the weakest, flagged weak, sit up to 0.4 % off at this noise, the median within
    0.03 %), as many as the two-channel file of the same hit does in the same band."""
    from identify.recordings.tap_quirks import real_like_plate, with_hum, with_snr

    plate = real_like_plate()
    hit = Session(plate, n_hits=1, seed=1, options=TapOptions(pulse_ms=0.35, noise_rel=3e-5)).hits()[0]
    hit = with_hum(with_snr(hit, 40, np.random.default_rng(5)))
    write_wav(hit, tmp_path / "mono.wav", force_channel=False)
    write_wav(hit, tmp_path / "stereo.wav")
    response_only = extract_peaks([tmp_path / "mono.wav"])
    mono = response_only.table["frequency_hz"].to_numpy()
    stereo = extract_peaks([tmp_path / "stereo.wav"]).table["frequency_hz"].to_numpy()
    nearest = np.min(np.abs(mono[:, None] / plate.frequencies_hz[None, :] - 1), axis=1)
    assert np.all(nearest < 5e-3), mono[nearest >= 5e-3]
    assert np.median(nearest) < 3e-4
    lo, hi = response_only.band_hz  # without a force channel the band's top is not measured
    in_band = stereo[(stereo >= lo) & (stereo <= hi)]
    assert abs(len(mono) - len(in_band)) <= 2 and len(mono) >= 20


def test_uff_frf_record_is_used_as_averaged(tmp_path, hits):
    averaged = average_hits(hits, (20.0, 1000.0))
    lines = averaged.frequency_hz <= 1000.0
    write_uff(tmp_path / "frf.uff", frf=(averaged.frequency_hz[lines], averaged.h1[lines]))
    (record,) = read_uff(tmp_path / "frf.uff")
    assert isinstance(record, MeasuredFRF) and record.quantity == "acceleration"
    np.testing.assert_allclose(record.frf, averaged.h1[lines], rtol=1e-10)
    result = extract_peaks([tmp_path / "frf.uff"])
    assert len(result) == 4 and (result.table["quality"] == "single_hit").all()
    assert result.table["std_hz"].isna().all()
    np.testing.assert_allclose(
        result.table["frequency_hz"], extract_peaks(hits).table["frequency_hz"], atol=0.05
    )


# --- bad inputs: one line naming the file, the field and value, what is allowed, a fix ----


def _csv(tmp_path, text, name="hit.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _series(n=300, rate=48000.0):
    t = np.arange(n) / rate
    return pd.DataFrame(
        {"time_s": t, "force": np.exp(-(((t - 1e-3) / 2e-4) ** 2)), "acceleration": np.sin(t * 2000)}
    )


def _frame_csv(tmp_path, frame, name="hit.csv"):
    return _csv(tmp_path, frame.to_csv(index=False), name)


BAD_CSV = {
    "empty": ("", "empty"),
    "header only": ("time_s,force,acceleration\n", "no rows"),
    "unknown column": (
        lambda f: f.rename(columns={"acceleration": "acceleraton"}),
        "did you mean 'acceleration'",
    ),
    "missing force": (lambda f: f.drop(columns="force"), "missing column 'force'"),
    "two responses": (lambda f: f.assign(velocity=1.0), "exactly one response column"),
    "nan": (lambda f: f.assign(force=f["force"].where(f.index != 10)), "line 12: force = nan"),
    "text": (
        lambda f: f.astype(object).assign(
            acceleration=["x" if i == 5 else v for i, v in enumerate(f["acceleration"])]
        ),
        "line 7: acceleration = 'x' is not a number",
    ),
    "time backwards": (
        lambda f: f.assign(time_s=f["time_s"].where(f.index != 20, 0.0)),
        "line 22: time_s = 0 is not after",
    ),
    "uneven time": (
        lambda f: f.assign(time_s=f["time_s"] * np.where(f.index > 100, 1.01, 1.0)),
        "evenly spaced",
    ),
    "too short": (lambda f: f.iloc[:100], "100 samples, need at least 256"),
    "binary junk": (b"\x00\xff\xfe" * 50, "cannot read as CSV"),
}


@pytest.mark.parametrize("case", BAD_CSV)
def test_bad_csv_is_one_line_error(tmp_path, case):
    content, expected = BAD_CSV[case]
    if callable(content):
        path = _frame_csv(tmp_path, content(_series()))
    elif isinstance(content, bytes):
        path = tmp_path / "hit.csv"
        path.write_bytes(content)
    else:
        path = _csv(tmp_path, content)
    with pytest.raises(MeasurementError) as info:
        read_recordings([path])
    message = str(info.value)
    assert isinstance(info.value, ValueError)
    assert "\n" not in message and message.startswith("hit.csv: ") and expected in message, message


def test_sample_rate_rules(tmp_path):
    with_time = _frame_csv(tmp_path, _series(rate=48000.0))
    with pytest.raises(MeasurementError, match=r"sample rate of 48000 Hz but sample_rate = 44100 Hz; drop"):
        read_csv(with_time, sample_rate=44100)
    assert read_csv(with_time, sample_rate=48000).sample_rate == 48000
    no_time = _frame_csv(tmp_path, _series().drop(columns="time_s"), "no_time.csv")
    with pytest.raises(
        MeasurementError, match=r"no_time.csv: no time_s column and no sample rate; .*--sample-rate"
    ):
        read_csv(no_time)
    with pytest.raises(MeasurementError, match=r"sample_rate = -5 must be a positive number of Hz"):
        read_csv(no_time, sample_rate=-5)
    slow = _frame_csv(tmp_path, _series(rate=44100.0), "slow.csv")
    with pytest.raises(
        MeasurementError, match=r"slow.csv: sample rate 44100 Hz differs from hit.csv's 48000 Hz"
    ):
        read_recordings([with_time, slow])


def test_bad_files_and_mixtures(tmp_path, hits):
    with pytest.raises(MeasurementError, match=r"missing.csv: no such file"):
        read_recordings([tmp_path / "missing.csv"])
    with pytest.raises(MeasurementError, match=r"hit.mat: cannot read as a MAT file"):
        read_recordings([_csv(tmp_path, "x", "hit.mat")])
    with pytest.raises(
        MeasurementError, match=r"hit.xlsx: file type '.xlsx' is not supported; allowed: .csv, .wav"
    ):
        read_recordings([_csv(tmp_path, "x", "hit.xlsx")])
    with pytest.raises(MeasurementError, match=r"no recordings given"):
        read_recordings([])
    junk = tmp_path / "junk.wav"
    junk.write_bytes(b"RIFF1234WAVEjunk")
    with pytest.raises(MeasurementError, match=r"junk.wav: cannot read as WAV"):
        read_recordings([junk])
    from scipy.io import wavfile

    wavfile.write(tmp_path / "three.wav", 48000, np.zeros((1000, 3), dtype=np.float32))
    with pytest.raises(MeasurementError, match=r"three.wav: 3 channels; allowed: 2 \(force, response\) or 1"):
        read_recordings([tmp_path / "three.wav"])
    write_wav(hits[0], tmp_path / "a.wav")
    with pytest.raises(
        MeasurementError, match=r"a.wav: the WAV header says 48000 Hz but sample_rate = 44100 Hz"
    ):
        read_recordings([tmp_path / "a.wav"], sample_rate=44100)
    write_wav(hits[1], tmp_path / "b.wav", force_channel=False)
    with pytest.raises(
        MeasurementError, match=r"b.wav: has a force channel where a.wav has none \(or the reverse\)"
    ):
        read_recordings([tmp_path / "a.wav", tmp_path / "b.wav"])
    write_csv(hits[0], tmp_path / "a.csv")
    with pytest.raises(MeasurementError, match=r"a.wav: response is response but a.csv has acceleration"):
        read_recordings([tmp_path / "a.csv", tmp_path / "a.wav"])
    (tmp_path / "none.uff").write_text("    -1\n    58\nnot a universal file\n")
    with pytest.raises(
        MeasurementError, match=r"none.uff: no type-58 record; export the FRF or the force and response"
    ):
        read_recordings([tmp_path / "none.uff"])
    write_uff(tmp_path / "frf.uff", frf=(np.arange(100.0), np.ones(100, dtype=complex)))
    text = (tmp_path / "frf.uff").read_text()
    (tmp_path / "garbled.uff").write_text(text.replace("1.00000000000e+00", "x.0000000000e+00", 3))
    with pytest.raises(
        MeasurementError, match=r"garbled.uff: cannot read as UFF \(Error when reading data-set"
    ):
        read_recordings([tmp_path / "garbled.uff"])
    (tmp_path / "cut.uff").write_text(text[:1500] + "\n    -1\n")
    with pytest.raises(
        MeasurementError, match=r"cut.uff: record 'accelerance' holds \d+ of its num_pts = 100 points"
    ):
        read_recordings([tmp_path / "cut.uff"])
    write_uff(tmp_path / "force.uff", hit=hits[0])
    text = (tmp_path / "force.uff").read_text()
    (tmp_path / "force.uff").write_text(text[: text.index("    -1", 10) + 7])  # the force record alone
    with pytest.raises(
        MeasurementError, match=r"force.uff: 1 time records with 1 force and 0 response; need one force"
    ):
        read_recordings([tmp_path / "force.uff"])
    write_uff(tmp_path / "hit.uff", hit=hits[0])
    with pytest.raises(MeasurementError, match=r"frf.uff: mixes an averaged FRF with time hits"):
        read_recordings([tmp_path / "hit.uff", tmp_path / "frf.uff"])


def test_every_hit_rejected_is_an_error():
    noise = Hit(
        "noise.csv",
        48000.0,
        np.random.default_rng(0).standard_normal(4800),
        np.random.default_rng(1).standard_normal(4800),
    )
    with pytest.raises(
        MeasurementError, match=r"every hit was rejected \(noise.csv: no hit: force peak only"
    ):
        extract_peaks([noise])
    force = hammer_force(TapOptions(duration_s=0.1))
    silent = Hit("silent.csv", 48000.0, np.zeros_like(force), force)
    with pytest.raises(MeasurementError, match=r"silent.csv: no response: the response channel is flat"):
        extract_peaks([silent])


def test_guide_is_validated(hits):
    with pytest.raises(
        MeasurementError, match=r"guide_hz = \[130.0, -5\] must be positive frequencies in Hz"
    ):
        extract_peaks(hits, guide_hz=[130.0, -5])
    with pytest.raises(MeasurementError, match=r"guide_hz = 'x' must be positive"):
        extract_peaks(hits, guide_hz="x")


def test_hits_in_memory_are_checked_together(hits):
    slow = Hit("slow", 44100.0, hits[1].response, hits[1].force)
    with pytest.raises(MeasurementError, match=r"slow: sample rate 44100 Hz differs from hit1's 48000 Hz"):
        extract_peaks([hits[0], slow])


def test_band_is_validated(hits):
    with pytest.raises(
        MeasurementError, match=r"band_hz = \(500, 100\) must satisfy 0 <= low < high <= 24000 Hz"
    ):
        extract_peaks(hits, band_hz=(500, 100))
    with pytest.raises(MeasurementError, match=r"band_hz = 'wide' must be two frequencies"):
        extract_peaks(hits, band_hz="wide")


def _as_binary_58(ascii_path, out_path, single: bool) -> None:
    """UFF 58 -> 58b as commercial front ends write it (the format's own description in
    pyuff's dataset_58): per record an ID line '58b' with byte order 1 (little endian),
    floating format 2 (IEEE), 11 ASCII header lines and the byte count, then the values as
    binary floats (single precision: ordinate data type 2) and the closing -1."""
    import struct

    lines = Path(ascii_path).read_text().splitlines()
    out, i = b"", 0
    while i < len(lines):
        header, j, values = lines[i + 2 : i + 13], i + 13, []
        while lines[j].strip() != "-1":
            values += [float(lines[j][20 * k : 20 * (k + 1)]) for k in range(len(lines[j]) // 20)]
            j += 1
        header[6] = f"{2 if single else 4:10d}" + header[6][10:]
        data = struct.pack(f"<{len(values)}{'f' if single else 'd'}", *values)
        out += (
            (
                f"{-1:6d}\n{58:6d}b{1:6d}{2:6d}{11:12d}{len(data):12d}{0:6d}{0:6d}{0:12d}{0:12d}\n"
                + "\n".join(header)
                + "\n"
            ).encode()
            + data
            + f"\n{-1:6d}\n".encode()
        )
        i = j + 1
    Path(out_path).write_bytes(out)


@pytest.mark.parametrize("single", [False, True])
def test_binary_uff58_gives_the_ascii_files_peaks(tmp_path, hits, single):
    """Binary 58b (double, and single precision as many front ends write) reads like the
    ASCII file: the same peaks to 1e-12 relative in double, 1e-6 in single
    (float32 carries 7 digits of each sample)."""
    ascii_paths, binary_paths = [], []
    for hit in hits:
        ascii_paths.append(tmp_path / f"{hit.source}.uff")
        binary_paths.append(tmp_path / f"{hit.source}_b.uff")
        write_uff(ascii_paths[-1], hit=hit)
        _as_binary_58(ascii_paths[-1], binary_paths[-1], single)
    expected = extract_peaks(ascii_paths).table["frequency_hz"].to_numpy()
    got = extract_peaks(binary_paths).table["frequency_hz"].to_numpy()
    assert len(got) == len(MODES.frequencies_hz)
    np.testing.assert_allclose(got, expected, rtol=1e-6 if single else 1e-12)
