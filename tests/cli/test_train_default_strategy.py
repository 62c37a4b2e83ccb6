"""``ltamp train``'s default strategy is the Python API's (``LearningConfig``), issue #21."""

from __future__ import annotations

import inspect

from ltamp_cli.cli.train import train_command
from ltamp_cli.learning.active import STRATEGIES, LearningConfig
from ltamp_cli.learning.defaults import DEFAULT_STRATEGY


def test_cli_and_api_share_the_default_strategy():
    parameter = inspect.signature(train_command).parameters["strategy"]
    assert parameter.default == LearningConfig().strategy == DEFAULT_STRATEGY
    assert DEFAULT_STRATEGY in STRATEGIES
