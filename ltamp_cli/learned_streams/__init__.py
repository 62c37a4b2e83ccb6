"""Learned streams: planner streams whose outputs come from a learned skill's sampler.

* :class:`~ltamp_cli.learned_streams.stream.LearnedStream` — context from the planner's input
  values, controls from a sampler of a cached trained model (never retrained), outputs from
  the controls, and the planner's "unusable downstream" feedback routed to kernel learning;
* :class:`~ltamp_cli.learned_streams.stream.LearnedStreamConfig` — what a problem YAML says
  about one learned stream (model directory, sampler, β, kernel file);
* :mod:`.kitchen` — ``GoodPour`` and ``GoodScoop`` for the Kitchen2D skills.
"""
