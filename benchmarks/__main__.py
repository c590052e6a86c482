"""Run every benchmark: ``python -m benchmarks``."""
from . import core, designer, diagnosis, identification, layerwise, peaks

core.main()
designer.main()
identification.main()
diagnosis.main()
layerwise.main()
peaks.main()
