# Vivado constraints for a generated MINRES core used as a top level (MinresCore_*): one clock, registered I/O.
# 150 MHz is the post place-and-route clock 001 reports for its design (Virtex-6, section VIII-C).
# Ports: clock, reset, s_axis_* (input frames), m_axis_* (output frames), s_axil_* (registers).
create_clock -name clock -period 6.667 [get_ports clock]
set_input_delay  -clock clock 0.500 [get_ports -filter {DIRECTION == IN && NAME != clock}]
set_output_delay -clock clock 0.500 [get_ports -filter {DIRECTION == OUT}]
