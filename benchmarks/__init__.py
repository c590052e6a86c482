"""Speed benchmarks; run all with ``make bench`` (python -m benchmarks)."""
