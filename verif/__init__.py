"""cocotb testbenches of the generated cores and their helpers."""
