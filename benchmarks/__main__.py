"""Run every benchmark: ``python -m benchmarks``.  (Guarded: the designer's and the
diagnosis's worker processes are spawned and import the main module.)"""
from . import core, designer, diagnosis, identification, layerwise, peaks, startup

if __name__ == "__main__":
    startup.main()
    core.main()
    designer.main()
    identification.main()
    diagnosis.main()
    layerwise.main()
    peaks.main()
