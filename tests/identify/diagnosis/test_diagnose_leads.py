"""Where to look when nothing pays and the misfit stays far from the noise: the verdict
says so (never "no effect is needed"), and the leads come from what the refits showed,
each with a code for programs."""

import json
from types import SimpleNamespace

import pytest

from identify.diagnosis import leads as leads_module
from identify.diagnosis.leads import IMPLAUSIBLE, OUTSIDE, PARTIAL, explained, leads
from identify.engine.statistics import FitStatistics
from studies import hidden_effect


def _fit(k: int, sum_squares: float, n: int = 20):
    return SimpleNamespace(statistics=FitStatistics(n, k, sum_squares, 0.01, True))


def _candidate(kind: str, k: int, sum_squares: float, implausible=()):
    return SimpleNamespace(
        kind=kind,
        fit=_fit(k, sum_squares),
        eligible=True,
        selectable=not implausible,
        plausible=not implausible,
        added=SimpleNamespace(implausible=tuple(implausible)),
    )


def test_a_drop_is_weighed_against_what_its_parameters_would_take_by_chance():
    """A refit with k more free parameters lowers chi^2 by about k units of its own
    residual variance even where its effect is absent (the mean of a chi^2 with k degrees
    of freedom, scaled by the over-dispersion).  State: chi^2 2000 on 20 - 4 dof."""
    state = _fit(4, 2000.0)
    # Two parameters more, chi^2 1600 left on 14 dof: the unit is 1600 / 14 = 114.3, the
    # drop 400 = 1.75 x (2 x 114.3).
    share, chance = explained(_candidate("a", 6, 1600.0), state)
    assert share == pytest.approx(0.2)
    assert chance == pytest.approx(400 / (2 * 1600 / 14))
    # At the noise (residual variance below the stated scatter) the unit is the scatter's.
    share, chance = explained(_candidate("b", 5, 5.0), _fit(4, 40.0))
    assert chance == pytest.approx(35.0)


def test_leads_name_partial_explainers_together_and_signs_before_them():
    state = _fit(4, 2000.0)
    step = SimpleNamespace(
        start=state,
        candidates=(
            _candidate("point_mass", 7, 1500.0),  # 500 / (3 x 1500 / 13) = 1.44 x chance
            _candidate("orientation", 5, 1700.0),  # 300 / (1700 / 15) = 2.6 x chance
            _candidate("suspension", 5, 1950.0),  # 0.44 x chance: what any parameter takes
            _candidate("transverse_shear", 6, 1000.0, ["G13 at its bound"]),
        ),
        above_start=(),
    )
    found = leads(step)
    assert [lead.code for lead in found] == [IMPLAUSIBLE, PARTIAL, OUTSIDE]
    assert "transverse_shear explains 50 %" in found[0].text
    assert "fit --effect point_mass --effect orientation" in found[1].text
    assert "suspension" not in found[1].text


def test_a_refit_above_what_it_contains_is_the_first_lead():
    """The round's ``above_start`` (refits that ended above the fit they contain, decided by
    ``AddedEffect.ended_above``) leads, before what the refits explain."""
    step = SimpleNamespace(
        start=_fit(4, 2000.0), candidates=(_candidate("adhesive", 5, 2100.0),), above_start=("adhesive",)
    )
    found = leads(step)
    assert [lead.code for lead in found] == [leads_module.FAILED_REFIT, OUTSIDE]
    assert found[0].text.startswith("adhesive:")


def test_nothing_pays_far_from_the_noise_says_where_to_look():
    """The paper's plate with a hidden 3 g sensor, offered only candidates that cannot hold
    it: nothing pays, 60 x the scatter is left; the verdict says the misfit is far from
    the noise, the orientation's implausible fit (it explains a quarter of the misfit by
    turning a layer 22 deg) is a lead, and the plate outside the candidates is the last."""
    o = hidden_effect.run_case("sensor_mass", ["rotary_inertia", "orientation", "suspension"])
    d = o.diagnosis
    assert not d.selected and not d.explained
    assert "far from the noise" in d.verdict and "no effect is needed" not in d.verdict
    codes = [lead.code for lead in d.leads]
    assert codes[0] == IMPLAUSIBLE and "orientation" in d.leads[0].text
    assert codes[-1] == OUTSIDE
    assert "where to look" in d.report()
    assert [lead["code"] for lead in json.loads(json.dumps(d.to_dict()))["leads"]] == codes
