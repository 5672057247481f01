"""Vu-Condat section of the benchmark: mpc_bench.splitting on the method `vucondat` of the ADMM core."""
from mpc_bench.splitting import SplittingSection


class Section(SplittingSection):
    name, label, method = "vucondat", "Vu-Condat", "vucondat"
