"""Round 5: a learned stream that knows its skill checks names *and* bounds; one that does
not fails in one line when its bindings cannot use the model's controls.

Before the fix a :class:`LearnedStream` built without ``context_names``/``control_names``
(the slide plugin's, the synthetic good-region domain's) checked only the context size: a
model of another skill with a 1-D context was used as the right one, and bindings indexing
a control value the model does not have stopped on an ``IndexError`` traceback inside the
planner; a model trained on other control bounds than the skill declares now was used
without a word. ``LearnedStream(..., skill=spec)`` now refuses both when the stream is built.
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ltamp_cli.backends.protocol import ParamSpace
from ltamp_cli.backends.synthetic import SyntheticBackend
from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.learned_streams.stream import LearnedStream, LearnedStreamConfig

REPO = Path(__file__).resolve().parents[2]
MODEL = REPO / "domains" / "synthetic_goodregion" / "model"
MOVING2D = SyntheticBackend().skills()["moving2d"]


def _stream(to_outputs=lambda control, phase: (tuple(control),), **names) -> LearnedStream:
    return LearnedStream(LearnedStreamConfig(MODEL, "adaptive"), lambda phase: [phase],
                         to_outputs, np.random.default_rng(0), **names)


def test_the_right_skill_draws_controls() -> None:
    outputs = next(_stream(skill=MOVING2D)(0.2))
    assert len(outputs[0]) == 2


@pytest.mark.parametrize("skill, message", [
    (replace(MOVING2D, control=ParamSpace(("x", "y"), (0.0, -1.0), (5.0, 1.0))),
     "trained on control x in [0, 4], but skill 'moving2d' declares [0, 5]"),
    (replace(MOVING2D, context=ParamSpace(("phase",), (0.0,), (2.0,))),
     "trained on context phase in [0, 1]"),
    (replace(MOVING2D, name="slide", control=ParamSpace(("speed", "spin"), (0.0, -1.0),
                                                        (4.0, 1.0))),
     "needs context (phase) and control (speed, spin)"),
])
def test_a_skill_the_model_was_not_trained_on_is_refused(skill, message: str) -> None:
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("[", r"\[").replace("]", r"\]")):
        _stream(skill=skill)


def test_names_that_contradict_the_skill_are_refused() -> None:
    with pytest.raises(InputError, match="control_names"):
        _stream(skill=MOVING2D, control_names=("a", "b"))
    with pytest.raises(InputError, match="expects the skill's SkillSpec"):
        _stream(skill="moving2d")


def test_bindings_that_cannot_use_the_models_controls_fail_in_one_line() -> None:
    stream = _stream(lambda control, phase: (float(control[2]),))  # expects 3 controls
    with pytest.raises(InputError) as error:
        next(stream(0.2))
    assert "2 value(s): x, y" in str(error.value) and "IndexError" in str(error.value)
    assert "\n" not in str(error.value)


def _solve(tmp_path: Path, streams_text: str) -> tuple[int, list[str]]:
    domain = tmp_path / "domain"
    domain.mkdir(parents=True)
    for name in ("domain.pddl", "stream.pddl"):
        (domain / name).write_text((REPO / "domains/synthetic_goodregion" / name).read_text())
    (domain / "streams.py").write_text(streams_text)
    problem = (REPO / "problems/examples/synthetic_goodregion.yaml").read_text()
    problem = (problem.replace("../../domains/synthetic_goodregion/streams.py",
                               str(domain / "streams.py"))
               .replace("../../domains/synthetic_goodregion", str(domain))
               .replace("model: model", f"model: {MODEL}")
               .replace("sampler: diverse-lk", "sampler: adaptive"))
    path = tmp_path / "problem.yaml"
    path.write_text(problem)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--max-time", "20", "--no-stats"])
    return int(done.value.code or 0), [line for line in err.getvalue().splitlines() if line]


STREAMS = '''
import numpy as np
from ltamp_cli.backends.protocol import ParamSpace, SkillSpec
from ltamp_cli.learned_streams.stream import LearnedStream, learned_stream_configs
from ltamp_cli.planner.streams import Binding, StreamInfo
from pathlib import Path

def make_streams(world, rng):
    config = learned_stream_configs(world, Path(__file__).parent)["sample-good-control"]
    learned = LearnedStream(config, lambda t: np.array([t]), TO_OUTPUTS, rng, SKILL)
    return {"sample-good-control": learned.binding(StreamInfo()),
            "test-clear": Binding(lambda t, c: True, StreamInfo(eager=True))}
'''


def test_cli_twin_refuses_in_one_line(tmp_path: Path) -> None:
    wrong_bounds = STREAMS.replace("TO_OUTPUTS", "lambda c, t: ((float(c[0]), float(c[1])),)")
    wrong_bounds = wrong_bounds.replace(", SKILL)", ", skill=SkillSpec('moving2d', "
                                        "ParamSpace(('phase',), (0.0,), (1.0,)), "
                                        "ParamSpace(('x', 'y'), (0.0, -1.0), (9.0, 1.0))))")
    code, lines = _solve(tmp_path / "a", wrong_bounds)
    assert code == 2 and len(lines) == 1 and "trained on control x in [0, 4]" in lines[0], lines
    three = STREAMS.replace("TO_OUTPUTS", "lambda c, t: ((float(c[2]), 0.0),)")
    code, lines = _solve(tmp_path / "b", three.replace(", SKILL)", ")"))
    assert code == 2 and len(lines) == 1 and "IndexError" in lines[0], lines


def test_a_non_finite_context_is_one_line_not_infeasible(tmp_path: Path) -> None:
    """Before: an object `t1: 1e400` (a YAML string the bindings read with float(): inf)
    got "context outside the trained range, no samples" and the task was "infeasible"
    (exit 1); with `extrapolate: true` a ValueError traceback."""
    for value in (float("inf"), float("nan")):
        stream = LearnedStream(LearnedStreamConfig(MODEL, "adaptive", extrapolate=True),
                               lambda phase, v=value: [v], lambda c, p: (tuple(c),),
                               np.random.default_rng(0))
        with pytest.raises(InputError, match="non-finite context"):
            next(stream(0.2))
    problem = (REPO / "problems/examples/synthetic_goodregion.yaml").read_text()
    path = tmp_path / "problem.yaml"
    path.write_text(problem.replace("../../domains", str(REPO / "domains"))
                    .replace("t1: 0.15", "t1: 1e400").replace("diverse-lk", "adaptive"))
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as done:
        main(["solve", str(path), "--max-time", "20", "--no-stats"])
    lines = [line for line in err.getvalue().splitlines() if line]
    assert done.value.code == 2 and len(lines) == 1, lines
    assert "non-finite context (phase=inf)" in lines[0]
