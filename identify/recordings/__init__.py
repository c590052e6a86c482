"""Recordings -> FRF -> peaks: impact-test files read, hits averaged (H1, coherence), modal
peaks with std and damping; simulated tap tests and measurements."""
