"""Python bindings of the kitchen2d streams (Box2D Kitchen2D geometry + learned skills).

The scene (object sizes and their homes along the table) is drawn from ``world`` with the
planner's stream RNG *before anything else*, so the executor rebuilds the same arrangement
from the same seed (:func:`ltamp_cli.backends.box2d.scene.scene_from_world`). Initial poses
are symbolic PDDL objects and mean "the object's home".

GoodPour and GoodScoop are learned: the GP level-set models (``world.models``, paths
relative to this folder) are loaded once per planning run; for a context the stream yields
the most confident control ``θ* = argmax μ/σ`` first, then further controls with
``μ/σ > β`` (the relaxed threshold ``β = Φ⁻¹(λ Φ(φ(θ*)))``), all of them passing the skill's
start-collision test and the kitchen's checks (approach, swing, the pour must not touch the
target cup: the pour score does not penalise shoving it aside, a plan must). Values are documented
in :mod:`ltamp_cli.backends.box2d.tamp`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ltamp_cli.backends.box2d.scene import default_grasp, scene_from_world
from ltamp_cli.backends.box2d.skills import pour as pour_skill
from ltamp_cli.backends.box2d.skills import scoop as scoop_skill
from ltamp_cli.backends.box2d.tamp import KitchenGeometry, Point
from ltamp_cli.errors import InputError
from ltamp_cli.planner.streams import Binding, StreamInfo

HERE = Path(__file__).resolve().parent
DEFAULT_MODELS = {"pour": "../../models/kitchen2d/pour", "scoop": "../../models/kitchen2d/scoop"}


class LearnedControls:
    """Confident controls of one learned skill for a context and a placement.

    ``valid(context, controls (n, d)) -> (n,) bool`` is the skill's start-collision test
    (vectorised); ``feasible(control) -> bool``, given per query, is the kitchen's own check
    (approach and swing clear of everything else). ``θ*`` is the most confident control
    among ``n`` random valid *and feasible* controls; later ones are the other candidates
    with ``μ/σ > β``, ``β = Φ⁻¹(λ Φ(μ/σ(θ*)))``, most confident first. Each batch of
    candidates is predicted in one vectorised GP call; the model is never refitted.
    """

    def __init__(self, model_dir: Path, valid: Callable[[np.ndarray, np.ndarray], np.ndarray],
                 rng: np.random.Generator, lam: float = 0.95, batch: int = 4000) -> None:
        from ltamp_cli.learning.model import LevelSetModel

        self.model = LevelSetModel.load(str(model_dir))
        self.valid = valid
        self.rng = rng
        self.lam = lam
        self.batch = batch

    def controls(self, context: np.ndarray, feasible: Callable[[np.ndarray], bool],
                 rounds: int = 5) -> Iterator[np.ndarray]:
        from ltamp_cli.learning.confidence import relaxed_beta

        beta: float | None = None
        space = self.model.spec.control
        for _ in range(rounds):
            candidates = space.sample_uniform(self.rng, self.batch)
            candidates = candidates[self.valid(context, candidates)]
            if len(candidates) == 0:
                continue
            mean, std = self.model.predict(np.repeat(context[None, :], len(candidates), 0),
                                           candidates)
            phi = mean / std
            order = np.argsort(-phi)
            for index in order:
                if beta is not None and phi[index] <= beta:
                    break
                if not feasible(candidates[index]):
                    continue
                if beta is None:
                    beta = relaxed_beta(float(phi[index]), self.lam)
                yield candidates[index]


def _pose(geometry: KitchenGeometry, name: str, pose: Any) -> Point:
    if isinstance(pose, str):
        return (round(geometry.spec.object(name).home, 4), round(geometry.top, 4))
    return (float(pose[0]), float(pose[1]))


def _tuple(values: np.ndarray) -> tuple[float, ...]:
    return tuple(round(float(v), 6) for v in values)


def make_streams(world: Mapping[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    scene = scene_from_world(world, rng)  # first draws: the executor repeats them
    geometry = KitchenGeometry(scene, motion_time=float(world.get("motion_time", 1.0)))
    models = {**DEFAULT_MODELS, **dict(world.get("models", {}) or {})}
    learned: dict[str, LearnedControls] = {}
    pour_config, scoop_config = pour_skill.PourConfig(), scoop_skill.ScoopConfig()

    def model(skill: str) -> LearnedControls:
        if skill not in learned:
            path = (HERE / str(models[skill])).resolve()
            if not (path / "model.json").is_file():
                raise InputError(f"world: models.{skill}: no model directory at {path}")
            module, config = (pour_skill, pour_config) if skill == "pour" else (
                scoop_skill, scoop_config)
            learned[skill] = LearnedControls(
                path, lambda c, u, m=module, k=config: m.valid_mask(c, u, k), rng)
        return learned[skill]

    def sample_placement(name: str, region: str) -> Iterator[tuple[Point]]:
        for pose in geometry.placements(name, region):
            yield (pose,)

    def sample_grasp(name: str) -> tuple[Point]:
        return (default_grasp(scene.object(name)),)

    def inverse_kinematics(name: str, pose: Any, grasp: Point) -> tuple[Any, ...] | None:
        found = geometry.kinematics(name, _pose(geometry, name, pose), tuple(grasp))
        return None if found is None else found

    def plan_free_motion(q1: Point, q2: Point) -> tuple[Any] | None:
        if q1 == q2:
            return None
        path = geometry.plan_motion(tuple(q1), tuple(q2))
        return None if path is None else (path,)

    def plan_holding_motion(name: str, grasp: Point, q1: Point, q2: Point
                            ) -> tuple[Any] | None:
        if q1 == q2:
            return None
        path = geometry.plan_motion(tuple(q1), tuple(q2), name, tuple(grasp))
        return None if path is None else (path,)

    def sample_pour(source: str, target: str, pose: Any, region: str
                    ) -> Iterator[tuple[Any, ...]]:
        src, dst = scene.object(source), scene.object(target)
        if source == target or not src.material:
            return
        p = _pose(geometry, target, pose)
        context = np.array([src.spec.width, src.spec.height, dst.spec.width, dst.spec.height])
        setups: dict[bytes, Any] = {}

        def feasible(control: np.ndarray) -> bool:
            setups[control.tobytes()] = geometry.pour_setup(source, target, p, control)
            return setups[control.tobytes()] is not None

        for control in model("pour").controls(context, feasible):
            grasp, conf, approach = setups[control.tobytes()]
            yield (grasp, conf, approach, _tuple(control))

    def sample_scoop(spoon: str, bowl: str, pose: Any) -> Iterator[tuple[Any, ...]]:
        cup = scene.object(bowl)
        if not cup.material:
            return
        p = _pose(geometry, bowl, pose)
        context = np.array([cup.spec.width, cup.spec.height])
        setups: dict[bytes, Any] = {}

        def feasible(control: np.ndarray) -> bool:
            setups[control.tobytes()] = geometry.scoop_setup(spoon, bowl, p, control)
            return setups[control.tobytes()] is not None

        for control in model("scoop").controls(context, feasible):
            grasp, conf, approach = setups[control.tobytes()]
            yield (grasp, conf, approach, _tuple(control))

    def sample_dump(spoon: str, grasp: Point, target: str, pose: Any, region: str
                    ) -> Iterator[tuple[Any, ...]]:
        p = _pose(geometry, target, pose)
        yield from geometry.dump_setups(spoon, tuple(grasp), target, p)

    def sample_stir(stirrer: str, grasp: Point, target: str, pose: Any, region: str
                    ) -> tuple[Any, ...] | None:
        p = _pose(geometry, target, pose)
        return geometry.stir_setup(stirrer, tuple(grasp), target, p)

    def test_cfree(a: str, pa: Any, b: str, pb: Any) -> bool:
        return geometry.cfree(a, _pose(geometry, a, pa), b, _pose(geometry, b, pb))

    def distance(q1: Point, q2: Point) -> float:
        return geometry.distance(tuple(q1), tuple(q2))

    cheap = StreamInfo(overhead=0.01)
    return {
        "sample-placement": Binding(sample_placement, cheap),
        "sample-grasp": Binding(sample_grasp, cheap),
        "inverse-kinematics": Binding(inverse_kinematics, cheap),
        "plan-free-motion": Binding(plan_free_motion, StreamInfo(overhead=0.05)),
        "plan-holding-motion": Binding(plan_holding_motion, StreamInfo(overhead=0.05)),
        "sample-pour": Binding(sample_pour, StreamInfo(p_success=0.8, overhead=0.5)),
        "sample-scoop": Binding(sample_scoop, StreamInfo(p_success=0.8, overhead=0.5)),
        "sample-dump": Binding(sample_dump, cheap),
        "sample-stir": Binding(sample_stir, cheap),
        "test-cfree": Binding(test_cfree, StreamInfo(eager=True, overhead=0.001)),
        "distance": distance,
        "holddistance": lambda name, grasp, q1, q2: distance(q1, q2),
    }
