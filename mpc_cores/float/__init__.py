"""Bit-exact model of the floating-point operator library."""
