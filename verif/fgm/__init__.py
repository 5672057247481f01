"""Fast gradient method (Algorithm 1 of 002): design flow, golden models, testbench."""
