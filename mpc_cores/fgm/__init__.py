"""Fast gradient method (Algorithm 1 of 002): design flow, certified design, golden models, report."""
