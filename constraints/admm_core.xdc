# Vivado constraints for a generated ADMM core used as a top level (AdmmCore_*): one clock, registered I/O.
# 400 MHz is the Virtex-6 figure of 002 Table III(b); relax it for slower parts.
create_clock -name clock -period 2.500 [get_ports clock]
set_input_delay  -clock clock 0.500 [get_ports -filter {DIRECTION == IN && NAME != clock}]
set_output_delay -clock clock 0.500 [get_ports -filter {DIRECTION == OUT}]
