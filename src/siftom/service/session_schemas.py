"""Request and response bodies of the session API (``/v1/sessions``)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, StringConstraints, model_validator

from siftom.assist.clarify import DEFAULT_COST, DEFAULT_THRESHOLD
from siftom.service.schemas import (
    MAX_ASR_NBEST,
    MAX_NBEST,
    MAX_TEXT_CHARS,
    ClarificationOut,
    ClarifyOptions,
    CommandProb,
    DecisionRuleName,
    GoalProb,
    Mode,
    NBestItem,
    PosteriorOut,
    RobotPlanOut,
    Strict,
)

MAX_GOALS = 5000  # the kitchen library has 151 recipes, the household space 252 goals
MAX_ACTIONS_PER_REQUEST = 200
SESSION_ID = r"^[A-Za-z0-9_-]{1,64}$"

ClassName = Annotated[str, StringConstraints(min_length=1, max_length=60)]
ActionLine = Annotated[str, StringConstraints(min_length=1, max_length=MAX_TEXT_CHARS)]


class GoalSpec(Strict):
    """A goal: at least ``counts[c]`` objects of class ``c`` on the target."""

    name: str = Field(min_length=1, max_length=100, examples=["salad"])
    counts: dict[ClassName, Annotated[int, Field(ge=1, le=20)]] = Field(
        min_length=1, max_length=20, examples=[{"tomato": 1, "lettuce": 1, "bowl": 1}])


class SessionCreate(Strict):
    """A robot's world and, optionally, its goal library."""

    world: dict[str, Any] = Field(
        description="siftom world JSON (docs/world.md) or a VirtualHome scene graph ({nodes, edges})",
        examples=[{"places": [{"name": "counter", "kind": "surface", "room": "kitchen", "pos": [0, 0]},
                              {"name": "fridge", "kind": "container", "room": "kitchen", "pos": [2, 0]}],
                   "items": [{"name": "tomato_1", "class": "tomato", "at": "fridge"},
                             {"name": "lettuce_1", "class": "lettuce", "at": "fridge"}],
                   "target": "counter", "verb": "fetch",
                   "goals": [{"name": "salad", "counts": {"tomato": 1, "lettuce": 1}}]}])
    goals: list[GoalSpec] | None = Field(default=None, min_length=1, max_length=MAX_GOALS,
                                         description="the goal library (default: the world's own, else the domain's)")
    goal_space: Literal["household-table-v0", "kitchen-v0"] | None = Field(
        default=None, description="a built-in goal library instead of 'goals'")
    target: str | None = Field(default=None, min_length=1, max_length=200,
                               description="the place goals are about (a VirtualHome class name for a scene graph)")
    mode: Mode | None = Field(default=None, description="full SIFToM or an ablation (default: the setting "
                                                        "model.mode)")
    likelihood: Literal["auto", "phonetic", "llm"] | None = Field(
        default=None, description="instruction likelihood (default: the setting infer.likelihood, auto: acoustic "
                                  "for spoken instructions when Whisper is installed, phonetic for transcripts)")
    decide: DecisionRuleName | None = Field(
        default=None, description="the decision rule of this session's answers (default: the setting "
                                  "infer.decide, expected-benefit; docs/decisions.md)")

    @model_validator(mode="after")
    def _one_library(self) -> SessionCreate:
        if self.goals is not None and self.goal_space is not None:
            raise ValueError("give either 'goals' or 'goal_space', not both")
        return self


class ActionsRequest(Strict):
    """Observed actions, oldest first, in siftom's or VirtualHome's script format: the human's,
    and the robot's own (``walk(robot, fridge)``); or ``executed``, a command the robot carried
    out, which stands for the robot's plan of it."""

    actions: list[ActionLine] | None = Field(
        default=None, min_length=1, max_length=MAX_ACTIONS_PER_REQUEST,
        examples=[["[Walk] <fridge> (165)", "[Open] <fridge> (165)", "grab(human, milk.195, fridge.165)"]])
    executed: Annotated[str, Field(min_length=1, max_length=MAX_TEXT_CHARS)] | Annotated[
        list[Annotated[str, Field(min_length=1, max_length=MAX_TEXT_CHARS)]], Field(min_length=1, max_length=3)] | None = Field(
        default=None, examples=["fetch(cereal)", ["fetch(cereal)", "fetch(sugar)"]],
        description="a command the robot carried out (fetch(cereal), deliver(fork,3)), or the parts of a "
                    "request of several, in order (at most 3; an answer's carry_out): their plans from the "
                    "session's state are added as the robot's actions, so the world, the belief and the next "
                    "request's reading follow them")

    @model_validator(mode="after")
    def _one_of(self) -> ActionsRequest:
        if (self.actions is None) == (self.executed is None):
            raise ValueError("give either actions (a list of action lines) or executed (a command the robot "
                             "carried out, e.g. fetch(cereal))")
        return self
    after: int | None = Field(
        default=None, ge=0,
        description="how many actions the session held when this request was first sent; makes a retry safe: "
                    "a repeat of a request that was already applied is answered again (replayed: true) "
                    "instead of appending twice, and any other mismatch is a 409")


class InstructionRequest(Strict):
    """What was heard: a transcript or an N-best list."""

    transcript: str | None = Field(default=None, min_length=1, max_length=MAX_TEXT_CHARS,
                                   examples=["can you bring me the forks"])
    nbest: list[NBestItem] | None = Field(default=None, min_length=1, max_length=MAX_NBEST)
    top: int | None = Field(default=None, ge=1, le=100,
                            description="how many commands, goals and hypotheses to return (default: infer.top)")
    clarify: ClarifyOptions = Field(default_factory=ClarifyOptions)

    @model_validator(mode="after")
    def _one_source(self) -> InstructionRequest:
        if (self.transcript is None) == (self.nbest is None):
            raise ValueError("give exactly one of 'transcript' or 'nbest' (or send the audio as multipart)")
        if self.transcript is not None and not self.transcript.strip():
            raise ValueError("'transcript' is blank; give the words that were heard")
        return self


class AudioInstructionFields(Strict):
    """The non-file fields of a multipart instruction."""

    asr_nbest: int | None = Field(default=None, ge=1, le=MAX_ASR_NBEST)
    top: int | None = Field(default=None, ge=1, le=100)
    threshold: float = Field(default=DEFAULT_THRESHOLD, ge=0.0, le=1.0, description="clarify.threshold")
    cost: float = Field(default=DEFAULT_COST, ge=0.0, le=1.0, description="clarify.cost")


AUDIO_INSTRUCTION_SCHEMA: dict[str, Any] = {
    "title": "AudioInstructionForm",
    "description": "What was heard, as a WAV/FLAC/OGG recording transcribed on the server.",
    "type": "object",
    "required": ["audio"],
    "properties": {
        "audio": {"type": "string", "format": "binary", "description": "the recording"},
        "asr_nbest": {"type": "integer", "minimum": 1, "maximum": MAX_ASR_NBEST},
        "top": {"type": "integer", "minimum": 1, "maximum": 100},
        "threshold": {"type": "number", "minimum": 0, "maximum": 1, "default": DEFAULT_THRESHOLD},
        "cost": {"type": "number", "minimum": 0, "maximum": 1, "default": DEFAULT_COST},
    },
    "additionalProperties": False,
}


# ----- responses (documentation; the handlers build plain dicts) ----------------------------
class Belief(BaseModel):
    goals: list[GoalProb]
    commands: list[CommandProb]


class InstructionResponse(PosteriorOut):
    """The posterior given every action so far and what was heard, the question and the plan."""

    session: str
    vad: dict[str, Any] | None = None
    clarification: ClarificationOut
    plan: RobotPlanOut | None = None


class SessionView(BaseModel):
    """A session's state: the world's names, the actions so far, the belief from them, the last answer."""

    id: str
    created: float
    mode: str
    likelihood: str
    verb: str
    target: str
    num_goals: int
    classes: list[str]
    places: list[str]
    n_actions: int
    actions: list[str]
    state: dict[str, Any]
    belief: Belief
    last_instruction: InstructionResponse | None
    warnings: list[str]


class ActionsResponse(BaseModel):
    """What the lines became (siftom's form), the count so far and the belief from actions alone."""

    id: str
    added: list[str]
    n_actions: int
    state: dict[str, Any]
    belief: Belief
    replayed: bool = False
