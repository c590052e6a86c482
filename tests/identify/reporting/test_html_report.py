"""The self-contained HTML report: its parts found by parsing it, values rounded to their
uncertainty, one status line, and the page rendered in a real headless browser."""

import re
import shutil
import subprocess
from html.parser import HTMLParser

import numpy as np
import pandas as pd
import pytest

from identify.cli import main


class Page(HTMLParser):
    """Collects headings, tables (as rows of cell texts) and image sources."""

    def __init__(self):
        super().__init__()
        self.headings, self.tables, self.images = [], [], []
        self._heading = self._cell = None

    def handle_starttag(self, tag, attrs):
        if tag in ("h1", "h2"):
            self._heading = ""
        elif tag == "table":
            self.tables.append([])
        elif tag == "tr" and self.tables:
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "img":
            self.images.append(dict(attrs)["src"])

    def handle_endtag(self, tag):
        if tag in ("h1", "h2") and self._heading is not None:
            self.headings.append(self._heading.strip())
            self._heading = None
        elif tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append(self._cell.strip())
            self._cell = None

    def handle_data(self, data):
        if self._heading is not None:
            self._heading += data
        if self._cell is not None:
            self._cell += data


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fit") / "report"
    assert main(["fit", "--report", str(folder)]) == 0
    return folder


def test_report_has_header_parameters_and_embedded_figures(report):
    """Parsed: the provenance header (spec and measurement files with SHA-256, date,
    version), the parameters table (12 rows: value, std, unit, flags) equal to
    parameters.csv, and every figure embedded as a PNG data URI (no file references)."""
    page = Page()
    page.feed((report / "report.html").read_text())
    header = {row[0]: row[1] for row in page.tables[0]}
    assert {"specimen", "spec file", "measurement file", "date", "tool"} <= set(header)
    assert "SHA-256" in header["spec file"] and "SHA-256" in header["measurement file"]
    assert "Parameters (value ± 1 std)" in page.headings
    parameters = next(t for t in page.tables if t and t[0][:3] == ["parameter", "of", "value ± std (rel.)"])
    csv = pd.read_csv(report / "parameters.csv")
    assert len(parameters) - 1 == len(csv) == 12
    assert [row[0] for row in parameters[1:]] == csv["parameter"].tolist()
    shown = [float(row[2].split(" ± ")[0]) for row in parameters[1:]]
    # rounded to two digits of the std: within half a unit of the std's second digit
    assert np.all(np.abs(shown - csv["value"]) <= 0.051 * csv["std"])
    assert csv["unit"].fillna("").tolist()[:4] == ["GPa", "GPa", "GPa", ""]
    assert len(page.images) >= 3 and all(src.startswith("data:image/png;base64,") for src in page.images)


def test_values_rounded_to_their_uncertainty_and_one_status_line(report):
    """A lab reads ``67.8 ± 1.2 GPa (1.7 %)``: the value to the decimal of the std's second
    significant digit, the relative std in %; relative errors in %; the status said once
    (not "converged: converged"). parameters.csv and fit.json keep the full precision."""
    page = Page()
    text = (report / "report.html").read_text()
    page.feed(text)
    parameters = next(t for t in page.tables if t and t[0][2:3] == ["value ± std (rel.)"])
    cells = {row[0]: row[2] for row in parameters[1:]}
    # the bundled fit (Table 1: bottom coating E1 = 68 GPa) at 0.05 % scatter: E1 to 1.7 %
    assert re.fullmatch(r"6\d\.\d ± 1\.\d GPa \(1\.\d %\)", cells["bottom_coating.E1"]), cells
    for cell in cells.values():
        value, std = re.fullmatch(r"(\S+) ± (\S+) .*\(.* %\)", cell).groups()
        significant = std.lstrip("0.").replace(".", "")
        assert len(significant) == 2, f"std {std} not to two significant digits"
        assert len(value.partition(".")[2]) == len(std.partition(".")[2]), (
            f"{cell}: value and std decimals differ"
        )
    residuals = next(t for t in page.tables if t and "error_%" in t[0])
    assert all("e-" not in cell for row in residuals for cell in row), "relative errors in %, not 1e-05"
    status = re.search(r'<div class="status[^"]*">(.*?)</div>', text, re.S).group(1)
    words = re.sub(r"<[^>]+>", "", status).split(":")[0].strip()
    assert words == "converged" and re.sub(r"<[^>]+>", "", status).count("converged") == 1, status
    csv = pd.read_csv(report / "parameters.csv")
    assert csv["value"].map(lambda v: len(repr(v))).max() > 8, "the CSV keeps full precision"


@pytest.mark.skipif(
    shutil.which("chromium") is None, reason="needs Debian's chromium (apt-get install chromium)"
)
def test_report_renders_in_a_headless_browser(report, tmp_path):
    """Chromium renders the page offline to a screenshot: a real image, mostly white
    page with content (not blank, not an error page)."""
    shot = tmp_path / "shot.png"
    subprocess.run(
        [
            "chromium",
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={tmp_path / 'profile'}",
            f"--screenshot={shot}",
            "--window-size=1200,2400",
            (report / "report.html").as_uri(),
        ],
        check=True,
        timeout=120,
        capture_output=True,
    )
    from matplotlib.image import imread

    pixels = imread(shot)[..., :3]
    assert pixels.shape[:2] == (2400, 1200)
    dark = np.mean(pixels.mean(axis=2) < 0.5)
    assert 0.005 < dark < 0.5, "text and figures drawn on a light page"
    assert len(np.unique((pixels * 255).astype(int).reshape(-1, 3), axis=0)) > 50, "more than a blank page"
