"""ltamp: learn parameterised skills from few trials and plan with them."""

__version__ = "0.1.0"
