"""The search methods of ``recommend`` by name (``search``), light enough for the
command line's help to list them without importing the search."""

#: auto: exhaustive up to ``search.EXHAUSTIVE_LIMIT`` sets, else relaxation (cvxpy).
METHODS = ("auto", "exhaustive", "relaxation")

__all__ = ["METHODS"]
