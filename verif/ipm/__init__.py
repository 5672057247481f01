"""Testbench of the Stage 1 engine of the interior-point core (random programs and their data, cocotb scenarios)."""
