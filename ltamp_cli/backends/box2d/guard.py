"""A Kitchen observer that stops a trial whose Box2D simulation diverged.

A non-finite velocity spreads NaN to every touching body within a step, and Box2D then
crawls (about a second per step with NaN bounding boxes) instead of failing, so bodies are
checked while the trial runs, not only at its end.
"""

from __future__ import annotations

from Box2D import b2

from ltamp_cli.backends.box2d.world import Kitchen, Observer
from ltamp_cli.backends.sanity import BodyGuard, BodyState, StateLimits


class Box2DGuard:
    """Observer checking the dynamic bodies during a trial (a rotating slice per step, see
    :class:`~ltamp_cli.backends.sanity.BodyGuard`), then calling ``observer``.

    Raises :class:`~ltamp_cli.backends.sanity.PhysicsDiverged` from inside ``Kitchen.step``;
    call :meth:`final_check` after the trial to check every body once more.
    """

    def __init__(
        self, observer: Observer | None = None, every: int = 40, limits: StateLimits | None = None
    ) -> None:
        self.observer = observer
        self.kitchen: Kitchen | None = None
        self.guard = BodyGuard(self._bodies, _state, _name, every, limits)

    def __call__(self, kitchen: Kitchen) -> None:
        fresh = kitchen is not self.kitchen
        self.kitchen = kitchen
        self.guard.step(refresh=fresh)
        if self.observer is not None:
            self.observer(kitchen)

    def final_check(self) -> None:
        """Check every dynamic body of the last world stepped (none if it never stepped)."""
        self.guard.check_all()

    def _bodies(self) -> list[b2.body]:
        if self.kitchen is None:
            return []
        return [body for body in self.kitchen.world.bodies if body.type == b2.dynamicBody]


def _state(body: b2.body) -> BodyState:
    # Attribute access: iterating a b2Vec2 goes through Python-level SWIG lambdas (slow).
    position, velocity = body.position, body.linearVelocity
    return (position.x, position.y), (velocity.x, velocity.y)


def _name(body: b2.body) -> str:
    return str((body.userData or {}).get("name"))
