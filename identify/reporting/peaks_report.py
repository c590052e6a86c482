"""A peak list (``identify.recordings.peaks.PeakList``) as text and as figures, from what
it is handed: the peak table, the averaged FRF with the peaks, the stabilisation diagram
and the coherence."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fem.plotting import new_figure, save_figure


def peak_list_text(peaks) -> str:
    """A peak list (``recordings.peaks.PeakList``) as text: its band and hits, the peak
    table in display units (damping in %), the rejected hits and the notes."""
    title = (
        f"Peaks of configuration '{peaks.configuration}': {len(peaks)} modes in "
        f"{peaks.band_hz[0]:.1f}-{peaks.band_hz[1]:.1f} Hz from {peaks.frf.n_hits} hit(s) "
        f"({', '.join(peaks.frf.sources)})"
    )
    lines = [title, ""]
    if len(peaks):
        shown = (
            peaks.table.assign(
                damping_ratio=100 * peaks.table["damping_ratio"],
                damping_std=100 * peaks.table["damping_std"],
                flags=peaks.table["flags"].replace("", "good"),
            )
            .rename(columns={"damping_ratio": "damping_%", "damping_std": "damping_std_%"})
            .drop(columns="quality")
        )
        formats = {
            "frequency_hz": "{:.3f}",
            "std_hz": "{:.3f}",
            "damping_%": "{:.3f}",
            "damping_std_%": "{:.4f}",
            "coherence": "{:.4f}",
            "prominence_db": "{:.1f}",
            "snr": "{:.0f}",
            "peak_hz": "{:.2f}",
        }
        # pandas prints a missing value as na_rep before any formatter sees it.
        lines.append(
            shown.to_string(index=False, na_rep="-", formatters={k: v.format for k, v in formats.items()})
        )
    else:
        lines.append("no peaks found")
    if peaks.rejected:
        lines += ["", "Rejected hits:"] + [f"  {r.source}: {r.reason}" for r in peaks.rejected]
    if peaks.notes:
        lines += ["", "Notes:"] + [f"  {n}" for n in peaks.notes]
    return "\n".join(lines)


def plot_peaks(result, directory: str | Path, coherence_min: float) -> list[Path]:
    """frf.png (|H1| with the peaks), stabilisation.png (the diagram over |H1|) and
    coherence.png (with the ``coherence_min`` a line is flagged below) in ``directory``;
    returns the paths."""
    directory = Path(directory)
    frf, table = result.frf, result.table
    lines = frf.lines(result.band_hz)
    f, mag = frf.frequency_hz[lines], 20 * np.log10(np.abs(frf.h1[lines]) + 1e-300)
    at = np.interp(table["frequency_hz"], f, mag) if len(table) else np.array([])
    paths = []

    def save(fig, name):
        paths.append(save_figure(fig, directory / name))

    fig, ax = new_figure(figsize=(9, 4))
    ax.plot(f, mag, lw=0.8, color="0.2", label="|H1|" if frf.has_force else "response spectrum")
    good = (table["quality"] == "good").to_numpy()
    ax.plot(table["frequency_hz"][good], at[good], "v", color="tab:green", label="peak (good)")
    ax.plot(table["frequency_hz"][~good], at[~good], "v", color="tab:orange", label="peak (flagged)")
    for x, y, q in zip(table["frequency_hz"], at, table["quality"], strict=True):
        ax.annotate(
            f"{x:.1f}" + ("" if q == "good" else f"\n{q}"),
            (x, y),
            textcoords="offset points",
            xytext=(0, 6),
            ha="center",
            fontsize=7,
        )
    ax.set(
        xlabel="frequency [Hz]",
        ylabel="magnitude [dB]",
        title=f"{result.configuration}: averaged FRF and peaks",
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, "frf.png")

    if result.diagram is not None:
        d = result.diagram
        fig, ax = new_figure(figsize=(9, 5))
        ax.plot(d.frequency_hz[~d.stable], d.order[~d.stable], ".", ms=3, color="0.7", label="pole")
        ax.plot(d.frequency_hz[d.stable], d.order[d.stable], "+", ms=5, color="tab:blue", label="stable pole")
        for x in table["frequency_hz"]:
            ax.axvline(x, color="tab:green", lw=0.6, alpha=0.6)
        ax.set(
            xlabel="frequency [Hz]",
            ylabel="model order",
            title="LSCF stabilisation diagram",
            xlim=result.band_hz,
        )
        twin = ax.twinx()
        twin.plot(f, mag, lw=0.6, color="0.3")
        twin.set_ylabel("|H1| [dB]")
        ax.legend(fontsize=8, loc="upper left")
        save(fig, "stabilisation.png")

    if np.isfinite(frf.coherence[lines]).any():
        fig, ax = new_figure(figsize=(9, 3))
        ax.plot(f, frf.coherence[lines], lw=0.8)
        for x in table["frequency_hz"]:
            ax.axvline(x, color="tab:green", lw=0.6, alpha=0.6)
        ax.axhline(coherence_min, color="tab:red", lw=0.6, ls="--")
        ax.set(
            xlabel="frequency [Hz]",
            ylabel="coherence",
            ylim=(0, 1.05),
            title="coherence of the averaged hits",
        )
        ax.grid(alpha=0.3)
        save(fig, "coherence.png")
    return paths


__all__ = ["peak_list_text", "plot_peaks"]
