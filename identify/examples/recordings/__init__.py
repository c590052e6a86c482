"""One small example recording per supported format (one hit of a plate with modes at
500 and 1200 Hz, 0.3 s at 8 kHz), made by :mod:`identify.examples.recordings.make`."""

from pathlib import Path

FOLDER = Path(__file__).parent
#: format -> example file
EXAMPLES = {
    "CSV, time column printed with %.7g": FOLDER / "hit.csv",
    "CSV, integer ADC counts, no time column (--sample-rate 8000)": FOLDER / "hit_counts.csv",
    "WAV, 16-bit PCM, channels (force, response)": FOLDER / "hit.wav",
    "MATLAB .mat (v5), vectors force, acceleration and sample_rate": FOLDER / "hit.mat",
    "NI TDMS, channels force and acceleration with wf_increment": FOLDER / "hit.tdms",
    "UFF58 (ASCII), two time records (force: data type 13, acceleration: 12)": FOLDER / "hit.uff",
}
#: The example plate's modes [Hz] and the sample rate of the examples [Hz].
MODES_HZ = (500.0, 1200.0)
SAMPLE_RATE = 8000.0
