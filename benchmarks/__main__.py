"""Run every benchmark: ``python -m benchmarks``.  (Guarded: the designer's and the
diagnosis's worker processes are spawned and import the main module.)"""
from . import core, damping, designer, diagnosis, identification, layerwise, peaks

if __name__ == "__main__":
    core.main()
    designer.main()
    identification.main()
    diagnosis.main()
    layerwise.main()
    peaks.main()
    damping.main()
