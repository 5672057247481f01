"""The refusals of the front end, the design flows and the generator: each message names the rule and the values."""
from __future__ import annotations


class SpecError(ValueError):
    """Invalid problem specification; the message names the offending field."""


class DesignError(ValueError):
    """The requested core cannot be built; the message names the rule and the values."""


class GeneratorError(RuntimeError):
    """The Chisel generator refused the configuration or failed; the message carries its reason."""


# Products of the fixed-point golden models are Python/numpy int64 words: the widest product they hold exactly.
MODEL_PRODUCT_BITS = 62
