"""Benchmark and closed-loop tables of the generated cores."""
