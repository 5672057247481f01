"""Python verification package for the MPC solver cores."""
