"""cocotb testbenches of the FGM core."""
