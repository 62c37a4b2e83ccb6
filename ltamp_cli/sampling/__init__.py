"""Sampling controls from a learned skill model's high-probability super-level set.

Main entry points:

* :func:`~ltamp_cli.sampling.factory.make_sampler` — ``rejection``, ``adaptive``,
  ``diverse`` or ``diverse-lk`` sampler for a model and a context (endless iterator of
  physical controls ``(dθ,)``);
* :class:`~ltamp_cli.sampling.superlevel.SuperLevelSet` /
  :func:`~ltamp_cli.sampling.superlevel.build_superlevel_set` — the set ``Â_α`` itself;
* :class:`~ltamp_cli.sampling.kernel_learning.DiversityKernel` with
  :func:`~ltamp_cli.sampling.kernel_learning.load_kernel` /
  :func:`~ltamp_cli.sampling.kernel_learning.save_kernel` — Algorithm 5's learned kernel;
* :mod:`.metrics` — FP, T50, N5 and the diversity ``D(S)``.
"""
