"""Fixed-point dual gradient projection (iteration (35) of 003) for MPC with input and state constraints: the QP
form, the design flow of (36)/(37), the golden models and the report."""
