"""`make soak`: random configurations of a core kind against its golden model (run), their report (report) and
what a kind declares to be soaked (space)."""
