"""Test planning: which known plates to bond where, scored by the conditioning of the
global sensitivity matrix (seed paper sections 4.1, 4.3, 4.6).

``space`` reads the [design] table, ``candidates`` builds the configurations,
``problem`` solves them once each, ``scoring``/``design`` score a set, ``search``
recommends sets (exhaustive or ``relaxation``), ``refine`` tunes thicknesses,
``check`` and ``sweep`` judge and explore the spec's own design; ``cli`` is plan-tests.
"""
