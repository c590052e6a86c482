"""Run every benchmark: ``python -m benchmarks``."""
from . import core, designer, identification

core.main()
designer.main()
identification.main()
