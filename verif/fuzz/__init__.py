"""Protocol fuzz of the generated cores: AXI4-Lite, AXI4-Stream and reset, for every core kind."""
