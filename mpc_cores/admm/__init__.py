"""ADMM (Algorithm 2 of 002) on the sparse form: design flow, golden models, closed-loop control, report."""
