"""What a clarifying question costs the team: the time of the spoken exchange, in world steps.

The cost is a stated model, not a tuned constant (docs/decisions.md):

* **the human's time** to hear the question and answer it: the words of the question and of
  the answer at a conversational speaking rate (``speaking_rate_wpm``, ~150 words per minute
  for English conversation), plus the gap before each turn (``turn_gap_s``);
* **the robot's time**: it waits for the answer and recognises it (``robot_latency_s``) before
  it moves;
* both stop for the exchange, so the team's completion time grows by its duration, converted
  to the simulation's steps with ``step_seconds`` (one step is a metre walked or one grab, put
  or open: about one second for a person at home, docs/world.md).

The chance that the answer is misheard is the other half of the price; it enters through the
question's value (the answer channel, ``Situation.answer_reliability``, measured by
``siftom bench answer-grammar``), not through this time.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from siftom.errors import ObservationError

# conversational English, words per minute (typical conversational rates are 120-180 wpm)
DEFAULT_SPEAKING_RATE_WPM = 150.0
# seconds per world step: a metre walked at an indoor pace (~1 m/s with a load), or one grab /
# put / open (about a second each); the world counts both as one step
DEFAULT_STEP_SECONDS = 1.0
# silence before a turn starts: ~0.2 s between turns in conversation, per turn
DEFAULT_TURN_GAP_S = 0.2
# the robot's time to recognise the answer and start moving after the human stops speaking
DEFAULT_ROBOT_LATENCY_S = 0.5


@lru_cache(maxsize=8192)
def n_words(text: str) -> int:
    """Spoken words in a phrase ("Which one: two plates or three plates?" -> 7); a question's
    answer phrases are counted for every question valued, so the counts are kept."""
    return len([w for w in text.replace(":", " ").replace("?", " ").split() if any(ch.isalnum() for ch in w)])


@dataclass(frozen=True)
class QuestionCost:
    """The time model of one spoken exchange (module doc); every parameter has its unit."""

    speaking_rate_wpm: float = DEFAULT_SPEAKING_RATE_WPM
    step_seconds: float = DEFAULT_STEP_SECONDS
    turn_gap_s: float = DEFAULT_TURN_GAP_S
    robot_latency_s: float = DEFAULT_ROBOT_LATENCY_S

    def __post_init__(self) -> None:
        for k in ("speaking_rate_wpm", "step_seconds"):
            v = getattr(self, k)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and v > 0):
                raise ObservationError(f"{k} must be a positive number, got {v!r}")
        for k in ("turn_gap_s", "robot_latency_s"):
            v = getattr(self, k)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and v >= 0):
                raise ObservationError(f"{k} must be a non-negative number of seconds, got {v!r}")

    def seconds(self, question: str, answer: str) -> float:
        """Duration of the exchange: both turns spoken, their gaps, the robot's recognition."""
        words = n_words(question) + n_words(answer)
        return words * 60.0 / self.speaking_rate_wpm + 2 * self.turn_gap_s + self.robot_latency_s

    def steps(self, question: str, answer: str) -> float:
        """The exchange in world steps (what it adds to the team's completion time)."""
        return self.seconds(question, answer) / self.step_seconds

    @lru_cache(maxsize=4096)  # noqa: B019 -- frozen and hashable: the cache keys on the time model too
    def expected_steps(self, question: str, answers: tuple[tuple[str, ...], ...]) -> float:
        """The cost before the answer is known: the mean answer length over the grammar's phrases."""
        phrases = [p for cell in answers for p in cell]
        if not phrases:
            return self.steps(question, "")
        mean_words = sum(n_words(p) for p in phrases) / len(phrases)
        return (n_words(question) + mean_words) * 60.0 / self.speaking_rate_wpm / self.step_seconds \
            + (2 * self.turn_gap_s + self.robot_latency_s) / self.step_seconds
