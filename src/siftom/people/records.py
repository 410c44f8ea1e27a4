"""The records people's pages send and store: an annotation form, an annotator joining, an
annotator's answer and a participant's agreement (each with the JSON the page or the JSONL file holds)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class AnswerForm:
    """What the annotation page's form offers for one scenario: its classes and, to deliver, counts."""

    verb: str
    classes: tuple[str, ...]
    max_count: int | None

    def to_json(self) -> dict[str, Any]:
        return {"verb": self.verb, "classes": list(self.classes), "max_count": self.max_count}


@dataclass(frozen=True)
class Joined:
    """An annotator's assignment: ``key`` is the annotator's secret (the page's links use it)."""

    annotator: str
    key: str
    assignment: int
    total: int

    def to_json(self) -> dict[str, Any]:
        return {"annotator": self.annotator, "key": self.key, "assignment": self.assignment, "total": self.total}


@dataclass(frozen=True)
class AnnotatorAnswer:
    """One stored answer of an annotator (a line of ``answers.jsonl``)."""

    annotator: str
    position: int
    id: str
    typed: str
    command: str
    seconds: float | None
    at: str

    def to_json(self) -> dict[str, Any]:
        return {"annotator": self.annotator, "position": self.position, "id": self.id, "typed": self.typed,
                "command": self.command, "seconds": self.seconds, "at": self.at}


@dataclass(frozen=True)
class Agreement:
    """A participant's agreement to the consent text: :meth:`to_json` is the line of
    ``participants.jsonl`` (the key's digest only); ``key`` is the secret, given in clear once."""

    participant: str
    at: str
    consent_sha1: str
    consent: str
    domain: str
    key_sha256: str
    key: str

    def to_json(self) -> dict[str, Any]:
        return {"participant": self.participant, "agreed": True, "at": self.at, "consent_sha1": self.consent_sha1,
                "consent": self.consent, "domain": self.domain, "key_sha256": self.key_sha256}
