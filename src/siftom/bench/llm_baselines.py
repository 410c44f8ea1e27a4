"""LLM baselines for the evaluator (paper, VLM baselines and "ablated SIFToM").

Both score every command of the domain with a language model and pick the most likely one;
they differ in what the prompt shows:

* ``llm-end-to-end``: only what was heard (the 1-best transcript), as a plain instruction
  follower reading noisy speech would see it.
* ``llm-ablated-siftom``: the symbolic scene (where objects are, what is on the target), the
  human's actions in ``Predicate(agent, object, location)`` form and the transcript; the model
  must reason about the intent itself, with no explicit inverse planning (paper, Models and
  Baselines: "ablated SIFToM").

Two ways to ask, chosen by what the backend offers (docs/llm.md):

* **scoring** (in-process SmolLM2, or an endpoint whose ``/completions`` echoes prompt
  log-probs): every candidate's description is scored as the continuation of the prompt and
  the most likely one wins;
* **chat** (chat-only endpoints, like the paper's Gemini): the numbered candidates are shown and
  the model answers with a number (generative multiple choice). With ``top_logprobs`` the
  answer's first-token distribution over the numbers is the choice distribution; an endpoint
  without log-probs is asked for :data:`VOTES` sampled answers instead (seeded), and the share
  of votes is the probability.

Configuration: :class:`siftom.backends.config.LLMConfig` (``SIFTOM_LLM_*``, ``--llm-*`` flags).
Answers and scores are cached on disk by the backends.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from siftom.backends.config import LLMConfig, llm_configured
from siftom.errors import BackendUnavailableError
from siftom.likelihood.llm import describe_command
from siftom.world.commands import MAX_COUNT, RobotCommand

LLM_MODELS = ("llm-end-to-end", "llm-ablated-siftom")

HEADER = ("A household robot helps a person. The person's spoken request was transcribed by a "
          "speech recogniser in a noisy room, so words may be wrong. Choose the robot command "
          "the person most likely meant.\n\n")
CHAT_SYSTEM = ("You help a robot that assists a person. The person's spoken request was "
               "transcribed by a speech recogniser in a noisy room, so words may be wrong. Choose "
               "the robot command the person most likely meant. Answer with the option's number only.")
VOTES = 8  # sampled answers when the endpoint gives no log-probs
TOP_LOGPROBS = 20  # the most OpenAI-style APIs return


def configured_backend() -> str | None:
    """The configured backend ("openai" or "llama"), or None when no LLM is configured
    (``SIFTOM_LLM_BACKEND``/``SIFTOM_LLM``/``SIFTOM_LLM_BASE_URL`` all unset)."""
    return LLMConfig.from_env().backend if llm_configured() else None


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
    """Pick a command with a language model: by scoring each candidate, or by chat.

    Args:
        scorer: a :class:`TextScorer` (scoring) and/or an object with ``chat`` (the
            OpenAI-compatible client has both).
        with_context: show the symbolic scene and the human's actions (ablated SIFToM).
        method: "auto" (score; fall back to chat when the endpoint cannot score prompts),
            "score" or "chat".
        votes: sampled answers when chat gives no log-probs.
        seed: seed of the sampled answers.
    """

    def __init__(self, scorer: Any, with_context: bool, method: str = "auto", votes: int = VOTES,
                 seed: int = 0) -> None:
        if method not in ("auto", "score", "chat"):
            raise BackendUnavailableError(f"method must be auto, score or chat, got {method!r}")
        if method == "chat" and not hasattr(scorer, "chat"):
            raise BackendUnavailableError("the chat method needs an OpenAI-compatible endpoint (--llm-backend openai)")
        self.scorer = scorer
        self.with_context = with_context
        self.method = method if hasattr(scorer, "chat") or method != "auto" else "score"
        self.votes = votes
        self.seed = seed
        self.used: Counter[str] = Counter()  # how each choice was made: score, chat-logprobs, chat-votes

    def prompt(self, scenario: Any, heard: str) -> str:
        ctx = scene_text(scenario) if self.with_context else ""
        return f"{HEADER}{ctx}Heard: \"{heard}\"\nCommand:"

    def choose(self, scenario: Any, heard: str, commands: Sequence[RobotCommand]) -> tuple[str, float]:
        """(command, its probability among the candidates)."""
        if self.method in ("auto", "score"):
            from siftom.backends.openai_compat import EndpointCapabilityError

            try:
                return self._choose_by_score(scenario, heard, commands)
            except EndpointCapabilityError:
                if self.method == "score" or not hasattr(self.scorer, "chat"):
                    raise
                self.method = "chat"  # this endpoint cannot score prompts: ask in chat from now on
        return self._choose_by_chat(scenario, heard, commands)

    def _choose_by_score(self, scenario: Any, heard: str, commands: Sequence[RobotCommand]) -> tuple[str, float]:
        prefix = self.prompt(scenario, heard)
        lp = np.array(self.scorer.score(prefix, [("", " " + describe_command(c)) for c in commands]))
        p = np.exp(lp - lp.max())
        p /= p.sum()
        k = int(np.argmax(p))
        self.used["score"] += 1
        return str(commands[k]), float(p[k])

    def chat_messages(self, scenario: Any, heard: str, commands: Sequence[RobotCommand]) -> list[dict[str, str]]:
        """The multiple-choice question: scene (ablated SIFToM only), what was heard, options."""
        ctx = scene_text(scenario) if self.with_context else ""
        options = "\n".join(f"{k}. {describe_command(c)}" for k, c in enumerate(commands, 1))
        user = (f"{ctx}Heard: \"{heard}\"\nOptions:\n{options}\n"
                f"Which option did the person mean? Answer with a number from 1 to {len(commands)}.")
        return [{"role": "system", "content": CHAT_SYSTEM}, {"role": "user", "content": user}]

    def _choose_by_chat(self, scenario: Any, heard: str, commands: Sequence[RobotCommand]) -> tuple[str, float]:
        from siftom.backends.openai_compat import EndpointCapabilityError

        client = self.scorer
        messages = self.chat_messages(scenario, heard, commands)
        n = len(commands)
        if getattr(self, "_logprobs_ok", True):
            try:
                data = client.chat(messages, top_logprobs=min(TOP_LOGPROBS, n), max_tokens=4, temperature=0.0)
            except EndpointCapabilityError:
                self._logprobs_ok = False
            else:
                p = _first_token_choice(data, n)
                if p is not None:
                    self.used["chat-logprobs"] += 1
                    k = int(np.argmax(p))
                    return str(commands[k]), float(p[k])
                # the endpoint ignores logprobs: use sampled votes from now on
                self._logprobs_ok = False
        counts = np.zeros(n)
        answers = 0
        for request in range(self.votes):  # endpoints that ignore n answer one sample per request
            if answers >= self.votes:
                break
            data = client.chat(messages, n=self.votes - answers, temperature=1.0, seed=self.seed + request,
                               max_tokens=4)
            for k in range(len(data["choices"])):
                answers += 1
                m = _answer_number(client.message_text(data, k), n)
                if m is not None:  # an answer that names no option is no vote
                    counts[m - 1] += 1
        self.used["chat-votes"] += 1
        if counts.sum() == 0:
            return "none", 1.0  # no usable answer: the robot does nothing
        k = int(np.argmax(counts))
        return str(commands[k]), float(counts[k] / counts.sum())


def _answer_number(text: str, n: int) -> int | None:
    m = re.search(r"\d+", text or "")
    if m is None:
        return None
    k = int(m.group())
    return k if 1 <= k <= n else None


def _first_token_choice(data: dict[str, Any], n: int) -> np.ndarray | None:
    """The distribution over options 1..n from the answer's first-token top log-probs (None when
    the answer carries no log-probs). Options missing from the top list get probability 0."""
    try:
        first = data["choices"][0]["logprobs"]["content"][0]
        alts = first.get("top_logprobs") or [first]
    except (KeyError, IndexError, TypeError):
        return None
    lp = np.full(n, -np.inf)
    for alt in alts:
        k = _answer_number(str(alt.get("token", "")).strip(), n)
        if k is not None and str(alt.get("token", "")).strip().isdigit():
            lp[k - 1] = np.logaddexp(lp[k - 1], float(alt.get("logprob", -np.inf)))
    if not np.isfinite(lp).any():
        return None
    p = np.exp(lp - lp.max())
    probs: np.ndarray = p / p.sum()
    return probs


def command_space(scenario: Any, max_count: int = MAX_COUNT) -> list[RobotCommand]:
    """Every command of the scenario's domain (what the baselines choose from)."""
    out: list[RobotCommand] = []
    for c in scenario.world.classes:
        n_obj = sum(1 for it in scenario.world.items if it.cls == c)
        top = min(n_obj, max_count) if scenario.verb == "deliver" else 1
        out.extend(RobotCommand(scenario.verb, c, k) for k in range(1, top + 1))
    return out


_CHOOSERS: dict[tuple[str, LLMConfig], LLMChooser] = {}


def chooser(model: str, config: LLMConfig | None = None) -> LLMChooser:
    """The (cached) chooser for an LLM baseline name, for ``config`` (default: the environment's,
    which must name an LLM)."""
    from siftom.likelihood.llm import make_backend

    if config is None:
        if not llm_configured():
            raise BackendUnavailableError(
                f"{model} needs a language model: set SIFTOM_LLM_BASE_URL and SIFTOM_LLM_MODEL "
                "(OpenAI-compatible endpoint) or SIFTOM_LLM_BACKEND=llama (pip install \"siftom[llm]\"), "
                "or pass --llm-backend / --llm-base-url / --llm-model; see docs/llm.md"
            )
        config = LLMConfig.from_env()
    key = (model, config)
    if key not in _CHOOSERS:
        _CHOOSERS[key] = LLMChooser(make_backend(config), with_context=model == "llm-ablated-siftom")
    return _CHOOSERS[key]
