"""Two Python-API trainings into one trial file (threads of one process): one trains, the
other is refused in one line, as a second ``ltamp train --out`` is; nothing is recorded
twice.

Before the fix ``learn_online`` took no lock (only the CLI did): two threads both resumed
from the same (empty) file and appended trials 0..19 each, 40 lines with every index twice,
a file the next resume refused ("trial 0 is recorded twice").
"""

from __future__ import annotations

import threading
from collections import Counter
from pathlib import Path

from ltamp_cli.backends import load_backend
from ltamp_cli.errors import InputError
from ltamp_cli.learning.active import LearningConfig, learn_online
from ltamp_cli.trials.record import TrialDataset

BUDGET = 20


def test_two_threads_training_into_one_file(tmp_path: Path) -> None:
    path = tmp_path / "trials.jsonl"
    outcomes: list[object] = []
    start = threading.Barrier(2)

    def train(seed: int) -> None:
        backend = load_backend("synthetic")
        start.wait()
        try:
            outcomes.append(learn_online(backend, "moving2d",
                                         LearningConfig(strategy="lse2", budget=BUDGET,
                                                        init=5, seed=seed),
                                         TrialDataset(path)))
        except InputError as error:
            outcomes.append(error)
        finally:
            backend.close()

    threads = [threading.Thread(target=train, args=(seed,)) for seed in (0, 1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=600)
    errors = [o for o in outcomes if isinstance(o, InputError)]
    assert len(outcomes) == 2 and len(errors) <= 1, outcomes
    for error in errors:
        assert "being written by another" in str(error) and "\n" not in str(error)
    counts = Counter(record.index for record in TrialDataset(path).read())
    # (no error: the second started after the first had finished, resumed, added nothing)
    assert set(counts) == set(range(BUDGET)) and max(counts.values()) == 1, counts
