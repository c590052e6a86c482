"""Notebook views (``_repr_html_``) are the HTML report's tables, not a ``<pre>`` of the
text, and they show the numbers the text report shows."""

import re

import identify
from identify.examples import COATED_PLATE, COATED_PLATE_MEASURED


def test_views_are_tables_with_the_reported_numbers():
    model = identify.load_spec(COATED_PLATE)
    data = identify.load_measurements(COATED_PLATE_MEASURED, model)
    prediction = identify.predict(model)
    fit = identify.fit(model, data)
    comparison = identify.compare(model, data)
    diagnosis = identify.diagnose(model, data)
    for result in (prediction, fit, comparison, diagnosis):
        view = result._repr_html_()
        assert "<table" in view and "<pre>" not in view and 'class="layer-id"' in view, type(result).__name__
    first = prediction.frequencies_hz["original"][0]
    assert f"{first:.3f}" in prediction._repr_html_()
    assert fit.status.value in fit._repr_html_() and fit.parameters[0].name in fit._repr_html_()
    patterns = re.findall(r"<td>([^<]+)</td>", comparison._repr_html_())
    assert all(p.name in patterns for p in comparison.patterns)
