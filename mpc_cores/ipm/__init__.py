"""The primal-dual interior-point core of 001: the sparse MPC QP, the float64 reference of Algorithm 1 and the
bit-exact model of the two-stage hardware (Stage 1 and the warm-started MINRES)."""
