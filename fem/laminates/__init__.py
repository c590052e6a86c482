"""Classical lamination theory: materials, layers and laminates (A, B, D and the inertia
terms with their derivatives), transverse shear stiffness, the layerwise (zig-zag)
laminate."""
