"""Run every benchmark: ``python -m benchmarks``."""
from . import core, designer, identification, peaks

core.main()
designer.main()
identification.main()
peaks.main()
