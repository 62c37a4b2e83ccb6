"""YAML problem schema: unknown keys, wrong types and missing fields -> one positioned line."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import yaml

from ltamp_cli.cli.app import main
from ltamp_cli.errors import InputError
from ltamp_cli.planner.algorithms.common import ALGORITHMS
from ltamp_cli.planner.problem_schema import (
    ALGORITHM_NAMES,
    SAMPLER_NAMES,
    SEARCH_NAMES,
    ProblemFile,
    validate_problem_document,
)
from ltamp_cli.planner.search.engine import SEARCH_ALGORITHMS
from ltamp_cli.sampling.factory import SAMPLER_NAMES as FACTORY_SAMPLERS
from ltamp_cli.yamlfile import YamlDocument

REPO = Path(__file__).resolve().parents[2]
SHIPPED = sorted((REPO / "problems").glob("*/*.yaml"))

# Line numbers below refer to this text (1-based); every case edits one line of it.
BASE = textwrap.dedent("""\
    name: demo
    domain: dom
    bindings: streams.py
    world:
      objects:
        cup: {kind: cup, width: [3.8, 4.4], fancy_backend_field: 1}
      regions:
        table: [[-0.25, 0.2], [-0.05, 0.4]]
      learned_streams:
        sample-pour:
          model: models/pour
          sampler: adaptive
          lambda: 0.95
      storage: [-18.0, 17.0]
    objects:
      cup: null
    init:
      - (Cup cup)
    goal: (Full cup)
    planner:
      max_time: 30
      algorithm: focused
""")


def error_for(text: str) -> InputError:
    with pytest.raises(InputError) as caught:
        validate_problem_document(YamlDocument("p.yaml", text))
    return caught.value


def edit(line: int, new: str) -> str:
    lines = BASE.splitlines()
    lines[line - 1] = new
    return "\n".join(lines) + "\n"


def test_base_document_is_valid_and_keeps_backend_fields() -> None:
    problem = validate_problem_document(YamlDocument("p.yaml", BASE))
    assert problem.world is not None and problem.world.objects is not None
    cup = problem.world.objects["cup"]
    assert cup.kind == "cup" and cup.model_extra == {"width": [3.8, 4.4],
                                                      "fancy_backend_field": 1}
    assert problem.world.model_extra == {"storage": [-18.0, 17.0]}
    assert problem.world.learned_streams is not None
    assert problem.world.learned_streams["sample-pour"].lam == 0.95
    assert problem.planner is not None and problem.planner.max_time == 30


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_shipped_problem_matches_the_schema(path: Path) -> None:
    validate_problem_document(YamlDocument(path))


@pytest.mark.parametrize(("line", "new", "where", "message"), [
    # unknown keys: at every level that is strict
    (1, "nmae: demo", (1, 7), "unknown field 'nmae': expected one of name, description, domain"),
    (21, "  max_tme: 30", (21, 12), "unknown field 'planner.max_tme': expected one of "
     "algorithm, max_time"),
    (13, "      lamda: 0.95", (13, 14), "unknown field "
     "'world.learned_streams.sample-pour.lamda': expected one of model, sampler, lambda"),
    # wrong types
    (21, "  max_time: soon", (21, 13), "field 'planner.max_time': expected a number, got "
     "'soon'"),
    (21, "  max_time: '30'", (21, 13), "field 'planner.max_time': expected a number, got '30'"),
    (21, "  max_time: true", (21, 13), "field 'planner.max_time': expected a number, got true"),
    (18, "  - 3", (18, 5), "field 'init[0]': expected a string, got 3"),
    (18, "  - {a: 1}", (18, 5), "field 'init[0]': expected a string, got a mapping"),
    (19, "goal: [1, 2]", (19, 7), "field 'goal': expected a string, got a list"),
    (6, "    cup: 5", (6, 10), "field 'world.objects.cup': expected a mapping, got 5"),
    (16, "  cup: {kind: [1]}", (16, 8), None),  # top-level object values are free-form
    (8, "    table: [[-0.25, 0.2], [-0.05, x]]", (8, 35),
     "field 'world.regions.table[1][1]': expected a number, got 'x'"),
    (11, "      model: 3", (11, 14),
     "field 'world.learned_streams.sample-pour.model': expected a string, got 3"),
    (6, "    cup: {kind: 7}", (6, 17), "field 'world.objects.cup.kind': expected a string"),
    # values out of range or not in a fixed set
    (12, "      sampler: divers", (12, 16), "field 'world.learned_streams.sample-pour.sampler': "
     "expected one of 'rejection', 'adaptive', 'diverse', 'diverse-lk', got 'divers'"),
    (22, "  algorithm: greedy", (22, 14), "field 'planner.algorithm': expected one of "
     "'adaptive', 'binding', 'focused', 'incremental', got 'greedy'"),
    (21, "  max_time: -1", (21, 13), "field 'planner.max_time': expected a number > 0, got -1"),
    (13, "      lambda: 1.5", (13, 15), "field 'world.learned_streams.sample-pour.lambda': "
     "expected a number <= 1, got 1.5"),
    # missing required fields: reported at the parent node
    (11, "      sampler_: x", (11, 17), "unknown field "
     "'world.learned_streams.sample-pour.sampler_'"),
    (6, "    cup: {width: 4}", (6, 10), "missing field 'world.objects.cup.kind': expected the "
     "object's kind"),
])
def test_bad_field_is_one_positioned_line(line: int, new: str, where: tuple[int, int],
                                          message: str | None) -> None:
    if message is None:
        validate_problem_document(YamlDocument("p.yaml", edit(line, new)))
        return
    error = error_for(edit(line, new))
    assert error.location is not None
    assert (error.location.line, error.location.column) == where, str(error)
    assert message in error.message, error.message
    assert "\n" not in str(error)
    assert str(error).startswith(f"p.yaml:{where[0]}:{where[1]}: ")


def test_missing_model_of_a_learned_stream_names_the_entry() -> None:
    text = BASE.replace("      model: models/pour\n", "")
    error = error_for(text)
    assert error.message == ("missing field 'world.learned_streams.sample-pour.model': "
                             "expected the path of a trained model directory")
    # reported at the entry (its mapping starts with its first key, line 11)
    assert error.location is not None and (error.location.line, error.location.column) == (11, 7)


def test_missing_domain_keeps_the_loader_message(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "p.yaml"
    path.write_text(BASE.replace("domain: dom\n", ""))
    with pytest.raises(SystemExit) as done:
        main(["check", str(path)])
    err = capsys.readouterr().err
    assert done.value.code == 2
    assert err.strip().splitlines() == [
        f"ltamp: error: {path}:1:1: 'domain' must name the domain folder (with domain.pddl)"]


def test_cli_reports_schema_errors_before_loading_the_domain(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The domain folder does not exist: the schema error comes first, exit 2, one line.
    path = tmp_path / "p.yaml"
    path.write_text(edit(22, "  algorithm: 5"))
    with pytest.raises(SystemExit) as done:
        main(["check", str(path)])
    err = capsys.readouterr().err
    assert done.value.code == 2
    assert "Traceback" not in err
    assert err.strip().splitlines() == [
        f"ltamp: error: {path}:22:14: field 'planner.algorithm': expected one of 'adaptive', "
        "'binding', 'focused', 'incremental', got 5"]


def test_names_match_the_modules_that_use_them() -> None:
    assert SAMPLER_NAMES == FACTORY_SAMPLERS
    assert ALGORITHM_NAMES == ALGORITHMS
    assert SEARCH_NAMES == SEARCH_ALGORITHMS


def test_schema_fields_are_the_documented_planner_options() -> None:
    from dataclasses import fields

    from ltamp_cli.planner.algorithms.common import PlannerConfig

    planner = ProblemFile.model_fields["planner"].annotation
    assert planner is not None
    options = set(yaml.safe_load(BASE)["planner"])
    assert options <= {f.name for f in fields(PlannerConfig)}


@pytest.mark.parametrize(("message", "where"), [
    ("world.regions.table: expected [[x0, x1], [y0, y1]]", (8, 12)),
    ("world.objects.cup.width: expected a number", (6, 29)),
    ("world: storage: expected [x_low, x_high], got [5]", (14, 12)),
    ("world: layout: unknown field 'x'", (5, 3)),  # no layout: the world block
    ("world.learned_streams.sample-pour.nothing: bad", (11, 7)),  # deepest existing node
    ("world: 'objects' must map object names to descriptions", (5, 3)),
])
def test_world_errors_of_backends_point_at_the_field(message: str,
                                                     where: tuple[int, int]) -> None:
    from ltamp_cli.planner.problem import world_error_location

    location = world_error_location(YamlDocument("p.yaml", BASE), message)
    assert (location.line, location.column) == where


def test_bindings_world_error_gets_the_yaml_position(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "dom").mkdir()
    (tmp_path / "dom" / "domain.pddl").write_text(
        "(define (domain tiny) (:predicates (Thing ?x) (Done ?x))\n"
        "  (:action finish :parameters (?x) :precondition (Thing ?x) :effect (Done ?x)))\n")
    (tmp_path / "dom" / "stream.pddl").write_text(
        "(define (stream tiny) (:stream make-thing :outputs (?x) :certified (Thing ?x)))\n")
    (tmp_path / "bindings.py").write_text(
        "from ltamp_cli.errors import InputError\n"
        "def make_streams(world, rng):\n"
        "    raise InputError(f\"world.regions.table: expected [low, high], got "
        "{world['regions']['table']!r}\")\n")
    path = tmp_path / "p.yaml"
    path.write_text("domain: dom\nbindings: bindings.py\nworld:\n  regions:\n"
                    "    table: [1, 2, 3]\nobjects: {a: null}\ngoal: (Done a)\n")
    with pytest.raises(SystemExit) as done:
        main(["check", str(path)])
    err = capsys.readouterr().err
    assert done.value.code == 2
    assert err.strip().splitlines() == [
        f"ltamp: error: {path}:5:12: world.regions.table: expected [low, high], got [1, 2, 3]"]
