"""The finite-element solve of a free plate: the mesh, unit matrices assembled once per
mesh, the free-free modal solve, mode shapes and labels, exact sensitivities, attached
masses and springs."""
