"""Run every benchmark: ``python -m benchmarks``."""
from . import core

core.main()
