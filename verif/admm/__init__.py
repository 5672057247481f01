"""ADMM (Algorithm 2 of 002) for input-rate and soft-state constrained MPC: sparse QP, design flow, golden models."""
