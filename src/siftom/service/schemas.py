"""Request and response bodies of the HTTP API (pydantic), validated before any work is done."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from siftom.assist.clarify import DEFAULT_COST, DEFAULT_THRESHOLD
from siftom.inference.model import MODES
from siftom.speech.tts import DEFAULT_VOICE, VOICES

# Bounds on what one request may ask for; each keeps a request's work small and predictable.
MAX_TEXT_CHARS = 500  # a spoken instruction is a sentence, not a paragraph
MAX_NBEST = 20  # ASR engines give a handful of hypotheses; more only costs time
MAX_ASR_NBEST = 10  # hypotheses the server's recogniser may be asked for (the default is the most)
MAX_ACTIONS = 200  # far more than any registered scenario's observed actions
MAX_SCENARIO_ID = 200
MAX_SAY_CHARS = 300  # about 20 s of speech at the default rate

Mode = Literal["full", "speech-only", "action-only"]  # == inference.model.MODES (tested)
DecisionRuleName = Literal["map", "expected-benefit", "ask-or-act", "teammate"]  # == assist.decide.RULES (tested)
NoiseKind = Literal["white", "pink", "brown", "babble", "hum"]
VoiceName = Literal[tuple(VOICES)]  # type: ignore[valid-type]


class Strict(BaseModel):
    """Unknown fields are an error (a typo such as ``transcipt`` must not be ignored)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class NBestItem(Strict):
    """One ASR hypothesis: the words and a natural-log score (higher is better)."""

    text: str = Field(min_length=1, max_length=MAX_TEXT_CHARS, examples=["pass me the cereal"])
    score: float = Field(default=0.0, ge=-1e9, le=1e9, examples=[-3.2])


class ClarifyOptions(Strict):
    """When the robot asks instead of acting (see docs/service.md): p_MAP < threshold and EVI > cost."""

    threshold: float = Field(default=DEFAULT_THRESHOLD, ge=0.0, le=1.0)
    cost: float = Field(default=DEFAULT_COST, ge=0.0, le=1.0)


class InferFields(Strict):
    """Fields shared by the JSON and the audio (multipart) forms of ``POST /v1/infer`` (the options
    of inference itself are :class:`siftom.options.InferOptions`)."""

    scenario: str = Field(min_length=1, max_length=MAX_SCENARIO_ID, examples=["kitchen-cereal-v0"],
                          description="a registered scenario id (GET /v1/scenarios)")
    mode: Mode | None = Field(default=None, description="full SIFToM or an ablation (default: the server's "
                                                        "setting model.mode, full)")
    likelihood: str | None = Field(default=None, max_length=40,
                                   description="instruction likelihood; GET /healthz lists those this server "
                                               "offers (default: the setting infer.likelihood, auto: acoustic "
                                               "for a recording when Whisper is installed, else phonetic)")
    n_actions: int | None = Field(default=None, ge=0, le=MAX_ACTIONS,
                                  description="use only the first n observed actions (default: all)")
    top: int | None = Field(default=None, ge=1, le=100,
                            description="how many commands, goals and hypotheses to return (default: infer.top)")
    clarify: ClarifyOptions = Field(default_factory=ClarifyOptions)
    decide: DecisionRuleName | None = Field(default=None, description="decision rule (docs/decisions.md): "
                                            "teammate, expected-benefit, ask-or-act or map (default: the setting "
                                            "infer.decide, teammate)")


class InferRequest(InferFields):
    """An observation as JSON: a transcript or an N-best list (or neither: actions alone)."""

    transcript: str | None = Field(default=None, min_length=1, max_length=MAX_TEXT_CHARS,
                                   examples=["can you pass me the cereal"])
    nbest: list[NBestItem] | None = Field(default=None, min_length=1, max_length=MAX_NBEST)
    actions: list[str] | None = Field(
        default=None, max_length=MAX_ACTIONS,
        description="the human's actions from the scenario's start, replacing the recorded ones, "
                    "e.g. ['walk(human, fridge)', 'grab(human, milk, fridge)']")

    @model_validator(mode="after")
    def _one_source(self) -> InferRequest:
        if self.transcript is not None and self.nbest is not None:
            raise ValueError("give either 'transcript' or 'nbest', not both")
        if self.transcript is not None and not self.transcript.strip():
            raise ValueError("'transcript' is blank; give the words that were heard")
        if self.actions is not None and self.n_actions is not None:
            raise ValueError("give either 'actions' or 'n_actions', not both")
        if self.actions is not None and any(len(a) > MAX_TEXT_CHARS for a in self.actions):
            raise ValueError(f"each action must be at most {MAX_TEXT_CHARS} characters")
        return self


class SayRequest(Strict):
    """Text to speak, optionally mixed with synthetic noise at an SNR."""

    text: str = Field(min_length=1, max_length=MAX_SAY_CHARS, examples=["pass me the cereal"])
    voice: VoiceName = Field(default=DEFAULT_VOICE, description="GET /healthz lists the installed voices")  # type: ignore[valid-type]
    rate: float = Field(default=1.0, ge=0.5, le=2.0, description="speaking-rate multiplier")
    noise: NoiseKind | None = Field(default=None, description="synthetic background noise")
    snr: float = Field(default=10.0, ge=-10.0, le=40.0, description="SNR in dB over active speech")
    seed: int = Field(default=0, ge=0, le=2**31 - 1, description="seed of the noise excerpt")


# ----- responses (documentation; the handlers build plain dicts) ---------------------------
class Problem(BaseModel):
    """RFC 9457 problem details."""

    type: str
    title: str
    status: int
    detail: str
    errors: list[dict[str, Any]] | None = None


class CommandProb(BaseModel):
    command: str
    prob: float


class GoalProb(BaseModel):
    goal: str
    prob: float


class ClarificationOut(BaseModel):
    ask: bool
    command: str
    question: str
    options: list[str]
    p_map: float
    evi: float
    threshold: float
    cost: float
    reason: str


class RobotPlanOut(BaseModel):
    command: str
    actions: list[str]
    route: list[str]
    cost: float
    status: str
    nodes_expanded: int


class PosteriorOut(BaseModel):
    """``Posterior.to_json`` plus what was heard: shared by /v1/infer and session instructions."""

    command: str | None = Field(description="the command the robot carries out; null when it asks or does nothing")
    action: Literal["act", "ask", "none"] = Field(description="what the robot does")
    top_command: str = Field(description="the most probable command (for analysis)")
    top_prob: float
    decision: dict[str, Any] = Field(description="the decision rule, its action and its reason")
    rule: str = Field(default="", description="the decision rule that ran (teammate, expected-benefit, ask-or-act, map)")
    recogniser: str | None = Field(default=None, description="the speech recogniser that turned the audio into "
                                   "words (e.g. pocketsphinx-vocab); null when words were given")
    speech_heard: bool = True
    instruction_heard: bool = True
    message: str = ""
    commands: list[CommandProb]
    goals: list[GoalProb]
    hypotheses: list[dict[str, Any]]
    mode: str
    likelihood: str = Field(description="the instruction likelihood that scored what was heard "
                                        "(phonetic, acoustic, ...; never auto)")
    n_actions: int
    transcript: str
    seconds: float
    nbest: list[NBestItem]
    asr: dict[str, Any] | None = None
    # what the likelihood used besides the N-best, e.g. {"acoustic_mode": ..., "whisper_heard": ...}
    evidence: dict[str, Any] = Field(default_factory=dict)


class InferResponse(PosteriorOut):
    """The posterior (``Posterior.to_json``) plus what was heard, the question and the robot's plan."""

    scenario: str
    vad: dict[str, Any] | None = None
    clarification: ClarificationOut
    plan: RobotPlanOut | None = None


AUDIO_FORM_SCHEMA: dict[str, Any] = {
    "title": "AudioInferForm",
    "description": "An observation as audio: a WAV/FLAC/OGG file, transcribed on the server, then "
                   "inferred with the N-best list. Other fields as in InferRequest.",
    "type": "object",
    "required": ["scenario", "audio"],
    "properties": {
        "scenario": {"type": "string", "minLength": 1, "maxLength": MAX_SCENARIO_ID},
        "audio": {"type": "string", "format": "binary", "description": "the recording"},
        "mode": {"type": "string", "enum": list(MODES)},
        "likelihood": {"type": "string"},
        "n_actions": {"type": "integer", "minimum": 0, "maximum": MAX_ACTIONS},
        "asr_nbest": {"type": "integer", "minimum": 1, "maximum": MAX_ASR_NBEST},
        "top": {"type": "integer", "minimum": 1, "maximum": 100},
        "decide": {"type": "string", "enum": ["map", "expected-benefit", "ask-or-act", "teammate"]},
    },
    "additionalProperties": False,
}


class AudioFields(InferFields):
    """The non-file fields of the multipart form."""

    asr_nbest: int | None = Field(default=None, ge=1, le=MAX_ASR_NBEST)

