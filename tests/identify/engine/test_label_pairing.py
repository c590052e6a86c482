"""Pairing labelled measured modes with model modes at the start (``ModePairing.initial``,
``permits``): a label goes to the nearest-ranked model mode that holds its pattern,
a member of a mixed pair included, or whose nodal lines a lab would count so."""

from types import SimpleNamespace

import numpy as np
import pytest

from fem.solver.mode_shapes import LABEL_SHARE, ORDER, label_of, label_shares
from identify.engine.pairing import ModePairing, permits
from studies import blind_diagnosis


def _solution(patterns: list[dict], in_plane=(), nodal_lines=None) -> SimpleNamespace:
    """A stand-in solution whose mode k has beam-basis shares ``patterns[k]`` ({(i, j): share});
    the modes ``in_plane`` are labelled so; nodal lines counted as the dominant pattern's
    unless ``nodal_lines`` ({k: (nx, ny)}) says otherwise."""
    coefficients = np.zeros((len(patterns), ORDER, ORDER))
    for k, shares in enumerate(patterns):
        for term, share in shares.items():
            coefficients[k][term] = np.sqrt(share)
    n = len(patterns)
    modes = SimpleNamespace(eigenvalues=np.arange(1.0, n + 1), shapes=np.eye(n))
    labels = tuple("in-plane" if k in in_plane else label_of(c) for k, c in enumerate(coefficients))
    counts = np.array([max(shares, key=shares.get) for shares in patterns])
    for k, lines in (nodal_lines or {}).items():
        counts[k] = lines
    counts[list(in_plane)] = -1
    moves_in_plane = np.isin(np.arange(n), list(in_plane))
    return SimpleNamespace(
        modes=modes,
        shape_coefficients=coefficients,
        labels=labels,
        nodal_lines=counts,
        moves_in_plane=moves_in_plane,
    )


#: Ten modes of distinct pure patterns, then a sensor-mixed pair at ranks 10 and 12.
_PURE = [(1, 1), (2, 0), (2, 1), (0, 2), (1, 2), (3, 0), (2, 2), (3, 1), (0, 3)]
_MIXED_PAIR = [{t: 1.0} for t in _PURE] + [
    {(3, 2): 0.35, (4, 0): 0.65},
    {(1, 3): 1.0},
    {(3, 2): 0.63, (4, 0): 0.37},
]


def test_mixed_member_at_its_rank_wins_over_a_purer_partner_further_away():
    """blind33's situation: the measured (3,2) at rank 10; the model's rank-10 mode is
    35 % (3,2) and 65 % (4,0), its partner at rank 12 is 63 % (3,2).  The label goes to
    rank 10 (the old rule, best affinity, took rank 12, 5 % higher in frequency)."""
    solution = _solution(_MIXED_PAIR)
    assert label_of(solution.shape_coefficients[9]) == "(3,2)+(4,0)", "precondition: a mixed label names both"
    labels = [""] * 9 + ["(3,2)"]
    pairing = ModePairing.initial("original", solution, list(range(1, 11)), labels)
    assert pairing.indices.tolist() == list(range(10))
    assert pairing.note == ""


def test_label_takes_a_pure_mode_out_of_order():
    """Measured (2,0) at rank 2 where the start model has (0,2) at rank 2 and (2,0) at
    rank 3: the label crosses the ranks, the unlabelled mode keeps the free one."""
    solution = _solution([{(1, 1): 1.0}, {(0, 2): 1.0}, {(2, 0): 1.0}, {(2, 1): 1.0}])
    pairing = ModePairing.initial("original", solution, [1, 2, 3, 4], ["", "(2,0)", "", ""])
    assert pairing.indices.tolist() == [0, 2, 1, 3]


def test_pattern_below_the_share_is_not_a_partner():
    """A pattern holding less than a mixed label's second term does not pair; the mode
    is paired by rank and the note says so."""
    weak = LABEL_SHARE * 0.9
    solution = _solution([{(1, 1): 1.0}, {(2, 0): 1.0 - weak, (0, 2): weak}, {(2, 1): 1.0}])
    pairing = ModePairing.initial("original", solution, [1, 2, 3], ["", "", "(0,2)"])
    assert pairing.indices.tolist() == [0, 1, 2]
    assert "no start-model mode shows the pattern of mode 3 (0,2)" in pairing.note


def test_peak_label_permits_both_members_of_a_mixed_pair():
    """Peak lists: a labelled peak may match either member of a mixed pair; the frequency
    match decides between them."""
    allowed = permits(_solution(_MIXED_PAIR), ["(3,2)", ""], [None, None])[0]
    assert np.flatnonzero(allowed[0]).tolist() == [9, 11]
    assert allowed[1].all()


def test_in_plane_mode_never_takes_a_label():
    """An in-plane mode's small deflection, normalised, can show any pattern: at rank 8
    it may not take the measured (3,1) from the bending (3,1) at rank 10 (held-out
    blind26's start, a cross-ply under bonded aluminium: 0.947 and 0.995)."""
    patterns = [{t: 1.0} for t in _PURE[:7]] + [{(3, 1): 0.947, (1, 1): 0.053}, {(0, 0): 1.0}, {(3, 1): 1.0}]
    solution = _solution(patterns, in_plane=(7, 8))
    pairing = ModePairing.initial("al_bottom", solution, list(range(1, 9)), [""] * 7 + ["(3,1)"])
    assert pairing.indices[7] == 9
    assert np.flatnonzero(permits(solution, ["(3,1)"], [None])[0][0]).tolist() == [9]


def test_blind33_sensor_mixed_mode_pairs_at_its_rank():
    """The real case (held-out blind33, a 5.76 g sensor on a foam sandwich, layerwise
    model at the true values): the 3-D mode 10, labelled (3,2) at 1584.9 Hz, pairs with
    the plate model's mode 10 (1589.8 Hz, '(3,2)+(4,0)'), not mode 12 (1664.8 Hz)."""
    case = blind_diagnosis.load("blind33_sandwich")
    model = blind_diagnosis.truth_model(case, "layerwise").with_options(modes=14)
    solution = model.solve("original")
    modes = case["configurations"][0]["modes"]
    assert modes[9]["label"] == "(3,2)"
    pairing = ModePairing.initial("original", solution, list(range(1, 11)), [""] * 9 + ["(3,2)"])
    assert pairing.indices[9] == 9
    assert solution.frequencies_hz[9] == pytest.approx(modes[9]["frequency_hz"], rel=0.005)


def test_a_mode_counted_as_the_label_is_permitted_though_its_pattern_is_spread():
    """A mode whose nodal lines bend spreads its deflection over several beam products
    (none holds ``LABEL_SHARE`` of the label's), but a lab counting its lines reads the
    label: the count permits it.  A mixed label is read by its pattern only."""
    pure = [(1, 3) if t == (3, 1) else t for t in _PURE]
    patterns = [{t: 1.0} for t in pure] + [{(2, 3): 0.45, (3, 0): 0.35, (3, 1): 0.2}, {(3, 1): 1.0}]
    solution = _solution(patterns, nodal_lines={9: (3, 1)})
    assert solution.shape_coefficients[9][3, 1] ** 2 < LABEL_SHARE, "precondition: the share alone forbids it"
    allowed = permits(solution, ["(3,1)", "(1,3)+(3,1)"], [None, None])[0]
    assert np.flatnonzero(allowed[0]).tolist() == [9, 10]
    assert np.flatnonzero(allowed[1]).tolist() == [7, 10]
    pairing = ModePairing.initial("original", solution, list(range(1, 11)), [""] * 9 + ["(3,1)"])
    assert pairing.indices[9] == 9


def test_blind08_bent_mode_pairs_with_its_shape_partner():
    """The real case (development blind08, a thick cross-ply, first-order shear at the
    true values): the 3-D mode 10, labelled (3,1) by its nodal lines, resembles the plate
    model's mode 10 most (the generator's MAC partner), whose pattern the beam products
    read as '(2,3)+(3,0)' but whose lines count (3,1); the share alone sent it to mode 11."""
    case = blind_diagnosis.load("blind08_cross_ply")
    modes = case["configurations"][0]["modes"]
    assert (modes[9]["label"], modes[9]["plate_mode"]) == ("(3,1)", 10)
    solution = blind_diagnosis.truth_model(case).with_options(modes=14).solve("original")
    assert solution.nodal_lines[9].tolist() == [3, 1]
    assert label_shares(solution.shape_coefficients, solution.labels, "(3,1)")[9] < LABEL_SHARE
    pairing = ModePairing.initial("original", solution, list(range(1, 11)), [""] * 9 + ["(3,1)"])
    assert pairing.indices[9] == 9
