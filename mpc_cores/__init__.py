"""MPC solver cores for FPGAs: problem spec and condensing, one subpackage per method (design flow, golden
models, report), generation of the SystemVerilog, register map and packaging, and the closed loop."""
