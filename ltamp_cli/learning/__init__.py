"""Learning skill constraints: GP super-level-set estimation with active learning.

Main entry points:

* :class:`~ltamp_cli.learning.model.LevelSetModel` — the learned GP model of a skill's score
  (``predict``, ``predict_normalized``, ``lengthscales``, ``most_confident_control``,
  ``beta``, ``save``/``load``); :class:`~ltamp_cli.learning.model.SkillModel` is the interface
  it shares with the baselines of :mod:`.baselines`.
* :func:`.active.learn_online` / :func:`.active.learn_from_pool` with a
  :class:`.active.LearningConfig` — the ``lse``/``lse2``/baseline learning loops.
* :mod:`.metrics` (F1, success rate), :mod:`.confidence` (β*, relaxed β), :mod:`.model_dir`
  (save/load), :mod:`.curves` (learning-curve PNG).

GP inputs are ordered ``[control..., context...]`` and min-max normalised to ``[-1, 1]``.
"""
