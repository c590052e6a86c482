"""Run every benchmark: ``python -m benchmarks``."""
from . import core, designer, identification, layerwise, peaks

core.main()
designer.main()
identification.main()
layerwise.main()
peaks.main()
