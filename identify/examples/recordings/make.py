"""Write the example recordings (seeded): ``python -m identify.examples.recordings.make``."""

import wave

import numpy as np
from scipy.io import savemat

from identify.recordings.tap_quirks import write_counts_csv, write_rounded_csv
from identify.recordings.tap_simulation import Modes, Session, TapOptions, write_uff

from . import EXAMPLES, FOLDER, MODES_HZ, SAMPLE_RATE


def example_hit():
    modes = Modes(MODES_HZ, [0.01, 0.008], [1.0, -0.6])
    options = TapOptions(sample_rate=SAMPLE_RATE, duration_s=0.3, pulse_ms=0.3, noise_rel=1e-4)
    return Session(modes, n_hits=1, seed=19, options=options).hits()[0]


def write_examples() -> None:
    from nptdms import ChannelObject, TdmsWriter

    hit = example_hit()
    write_rounded_csv(hit, FOLDER / "hit.csv")
    write_counts_csv(hit, FOLDER / "hit_counts.csv", bits=16, offset_counts=40)
    counts = np.column_stack(
        [np.rint(x / np.abs(x).max() * 20000) for x in (hit.force, hit.response)]
    ).astype("<i2")
    with wave.open(str(FOLDER / "hit.wav"), "wb") as w:
        w.setnchannels(2)
        w.setsampwidth(2)
        w.setframerate(int(SAMPLE_RATE))
        w.writeframes(counts.tobytes())
    savemat(
        FOLDER / "hit.mat", {"force": hit.force, "acceleration": hit.response, "sample_rate": SAMPLE_RATE}
    )
    properties = {"wf_increment": 1 / SAMPLE_RATE}
    with TdmsWriter(FOLDER / "hit.tdms") as writer:
        writer.write_segment(
            [
                ChannelObject("hit", "force", hit.force, properties=properties),
                ChannelObject("hit", "acceleration", hit.response, properties=properties),
            ]
        )
    write_uff(FOLDER / "hit.uff", hit=hit)
    assert all(path.exists() for path in EXAMPLES.values())


if __name__ == "__main__":
    write_examples()
