"""Trials: records of skill executions and the append-only datasets that hold them."""

from ltamp_cli.trials.record import TrialDataset, TrialRecord

__all__ = ["TrialDataset", "TrialRecord"]
