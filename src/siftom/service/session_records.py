"""The records a session is made of and answered with, as they cross JSON: what it was created
over (:class:`SessionSpec`), how it infers (:class:`SessionOptions`) and the answers to its
requests (:class:`SessionReply`), which the store keeps and a retried request gets again."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict


class SessionSpec(BaseModel):
    """A session's world and goal library, as the create request gave them (the store keeps it)."""

    model_config = ConfigDict(frozen=True, extra="ignore")
    world: dict[str, Any]  # siftom world JSON or a VirtualHome scene graph (docs/world.md)
    goals: list[dict[str, Any]] | None = None
    goal_space: str | None = None
    target: str | None = None


class SessionOptions(BaseModel):
    """How a session infers (``None``: the server's setting) and what its creation warned about."""

    model_config = ConfigDict(frozen=True, extra="ignore")
    mode: str | None = None
    likelihood: str | None = None
    decide: str | None = None
    warnings: tuple[str, ...] = ()


PENDING = "pending"  # an actions answer not written yet: (n_actions, added) to rebuild it from


@dataclass(frozen=True, eq=True)
class SessionReply:
    """The JSON answer to a session request: sent as it is, kept by the store, and given again
    unchanged to a retry with the same Idempotency-Key. Its shape is the endpoint's response
    model (:mod:`siftom.service.session_schemas`)."""

    body: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return self.body

    @classmethod
    def pending(cls, n_actions: int, added: list[str]) -> SessionReply:
        """The stand-in stored with actions before their answer is (see :attr:`pending_actions`)."""
        return cls({PENDING: [n_actions, list(added)]})

    @property
    def pending_actions(self) -> tuple[int, list[str]] | None:
        """For a :meth:`pending` stand-in, the action count and the actions added; else None."""
        got = self.body.get(PENDING)
        if got is None:
            return None
        n, added = got
        return int(n), list(added)


@dataclass(frozen=True)
class Prepared:
    """An answer prepared but not stored (``SessionManager.prepare``) and the session's revision
    it was made at: ``SessionManager.commit`` stores it only while that revision holds."""

    reply: SessionReply
    revision: tuple[int, int, int]
