"""How a test set is scored: the sensitivity-based scores, a set's design and its scores,
the prior points and robust scores, the Poisson plate."""
