"""Task-and-motion planning on the PyBullet Kitchen3D.

:mod:`.scene` (the problem's ``world`` → objects and regions), :mod:`.values` (planner
values: poses, grasps, arm confs and paths), :mod:`.grasping`, :mod:`.planning` (the
headless world answering IK, motion and collision queries for the streams),
:mod:`.skill_paths` (tool paths placed in the kitchen: learned pour and scoop, engineered dump,
stir and push). Executions are animated by :mod:`ltamp_cli.backends.pybullet.replay`.
The bindings are ``domains/kitchen3d/streams.py``; plans are replayed by
:mod:`ltamp_cli.backends.pybullet.executor`.
"""
