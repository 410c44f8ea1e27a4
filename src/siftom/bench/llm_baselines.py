"""LLM baselines for the evaluator (paper, VLM baselines and "ablated SIFToM").

Both score every command of the domain with a language model and pick the most likely one;
they differ in what the prompt shows:

* ``llm-end-to-end``: only what was heard (the 1-best transcript), as a plain instruction
  follower reading noisy speech would see it.
* ``llm-ablated-siftom``: the symbolic scene (where objects are, what is on the target), the
  human's actions in ``Predicate(agent, object, location)`` form and the transcript; the model
  must reason about the intent itself, with no explicit inverse planning (paper, Models and
  Baselines: "ablated SIFToM").

Scoring candidates instead of parsing free text works with any backend that gives log-probs:
the in-process SmolLM2 (``SIFTOM_LLM=llama``, needs the ``llm`` extra) or any OpenAI-compatible
``/v1/completions`` endpoint (``SIFTOM_LLM_BASE_URL`` + ``SIFTOM_LLM_MODEL``). Scores are cached
on disk by the backends.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from siftom.backends.scoring import TextScorer
from siftom.likelihood.llm import describe_command
from siftom.world.commands import RobotCommand

LLM_MODELS = ("llm-end-to-end", "llm-ablated-siftom")

HEADER = ("A household robot helps a person. The person's spoken request was transcribed by a "
          "speech recogniser in a noisy room, so words may be wrong. Choose the robot command "
          "the person most likely meant.\n\n")


def configured_backend() -> str | None:
    """'openai' when SIFTOM_LLM_BASE_URL is set, 'llama' when SIFTOM_LLM=llama, else None."""
    if os.environ.get("SIFTOM_LLM_BASE_URL"):
        return "openai"
    if os.environ.get("SIFTOM_LLM", "").lower() == "llama":
        return "llama"
    return None


def scene_text(scenario: Any) -> str:
    """The symbolic scene when the human speaks, and the human's actions, as prompt text."""
    w, now = scenario.world, scenario.now
    lines = ["Scene:"]
    for i, p in enumerate(w.places):
        objs = Counter(w.items[k].cls for k, loc in enumerate(now.item_at) if loc == i)
        if objs or i == scenario.target:
            state = "" if not p.closable else (" (open)" if now.is_open(i) else " (closed)")
            what = ", ".join(f"{n} {c}" for c, n in sorted(objs.items())) or "nothing"
            lines.append(f"- {p.name}{state} in the {p.room}: {what}")
    lines.append(f"The person works at the {w.places[scenario.target].name}.")
    lines.append("The person did: " + "; ".join(w.format_action(a) for a in scenario.actions))
    return "\n".join(lines) + "\n"


class LLMChooser:
    """Pick a command by the language model's log-probability of its description."""

    def __init__(self, scorer: TextScorer, with_context: bool) -> None:
        self.scorer = scorer
        self.with_context = with_context

    def prompt(self, scenario: Any, heard: str) -> str:
        ctx = scene_text(scenario) if self.with_context else ""
        return f"{HEADER}{ctx}Heard: \"{heard}\"\nCommand:"

    def choose(self, scenario: Any, heard: str, commands: Sequence[RobotCommand]) -> tuple[str, float]:
        """(command, its softmax probability among the candidates)."""
        prefix = self.prompt(scenario, heard)
        lp = np.array(self.scorer.score(prefix, [("", " " + describe_command(c)) for c in commands]))
        p = np.exp(lp - lp.max())
        p /= p.sum()
        k = int(np.argmax(p))
        return str(commands[k]), float(p[k])


def command_space(scenario: Any, max_count: int = 4) -> list[RobotCommand]:
    """Every command of the scenario's domain (what the baselines choose from)."""
    out = []
    for c in scenario.world.classes:
        n_obj = sum(1 for it in scenario.world.items if it.cls == c)
        top = min(n_obj, max_count) if scenario.verb == "deliver" else 1
        out.extend(RobotCommand(scenario.verb, c, k) for k in range(1, top + 1))
    return out


_CHOOSERS: dict[str, LLMChooser] = {}


def chooser(model: str, backend: str | None = None) -> LLMChooser:
    """The (cached) chooser for an LLM baseline name."""
    from siftom.errors import BackendUnavailableError
    from siftom.likelihood.llm import make_backend

    if model not in _CHOOSERS:
        backend = backend or configured_backend()
        if backend is None:
            raise BackendUnavailableError(
                f"{model} needs a language model: set SIFTOM_LLM_BASE_URL and SIFTOM_LLM_MODEL "
                "(OpenAI-compatible endpoint) or SIFTOM_LLM=llama (pip install \"siftom[llm]\")"
            )
        _CHOOSERS[model] = LLMChooser(make_backend(backend), with_context=model == "llm-ablated-siftom")
    return _CHOOSERS[model]
