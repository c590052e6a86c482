"""Where the model fails (``compare``) and which physical effects it misses (``diagnose``,
a forward selection)."""
