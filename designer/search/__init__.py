"""How test sets are searched: ranking (exhaustive or by relaxation), mirror designs
collapsed, thicknesses refined to stock."""
