"""A scripted vision model for kitchen-cereal-v0: the answers a perfect model would give.

The answers are built from the scenario's ground truth (its states and actions), not recorded
from a real model; :func:`handler` serves them from the fake OpenAI server, recognising each
frame by its SHA-256 and each question by its schema name.
"""

from __future__ import annotations

import base64
import hashlib
import json
from pathlib import Path
from typing import Any

from siftom.perception.scene import graph_from_world
from siftom.scenarios.base import get_scenario
from support.fake_openai import RecordedRequest, Reply, chat_answer

SCENARIO = "kitchen-cereal-v0"
STEPS = (0, 5, 10)  # frames: start, milk on the counter, bowl on the counter


def render_frames(folder: Path, steps=STEPS) -> list[Path]:
    from siftom.world.render import render_scenario

    sc = get_scenario(SCENARIO)
    return [render_scenario(sc, folder / f"frame{k:02d}.png", step=k, title=f"{SCENARIO} frame") for k in steps]


def scene_answer(step: int = 0) -> dict[str, Any]:
    sc = get_scenario(SCENARIO)
    graph = graph_from_world(sc.world, sc.states()[step]).to_json()  # in the scene schema: no null fields
    return {"nodes": [{k: v for k, v in n.items() if v is not None} for n in graph["nodes"]], "edges": graph["edges"]}


def actions_answer(a: int, b: int) -> dict[str, Any]:
    sc = get_scenario(SCENARIO)
    return {"actions": [sc.world.format_action(x) for x in sc.actions[a:b]]}


GOALS = {"target": "kitchen_counter", "goals": [
    {"name": "breakfast_cereal", "counts": [{"class": "cereal", "count": 1}, {"class": "milk", "count": 1},
                                            {"class": "bowl", "count": 1}]},
    {"name": "cereal_for_two", "counts": [{"class": "cereal", "count": 1}, {"class": "milk", "count": 1},
                                          {"class": "bowl", "count": 2}]},  # not in the recipe library
]}


def images(req: RecordedRequest) -> list[bytes]:
    """The decoded image parts of a chat request's last user message with images."""
    out = []
    for m in req.body["messages"]:
        if isinstance(m["content"], list):
            for p in m["content"]:
                if p["type"] == "image_url":
                    out.append(base64.b64decode(p["image_url"]["url"].split(",", 1)[1]))
    return out


def schema_name(req: RecordedRequest) -> str:
    return req.body["response_format"]["json_schema"]["name"]


def handler(frames: list[Path], steps=STEPS, overrides: dict[str, Any] | None = None):
    """A chat handler answering each question as a perfect model would (``overrides`` by schema)."""
    step_of = {hashlib.sha256(p.read_bytes()).hexdigest(): k for p, k in zip(frames, steps, strict=True)}

    def handle(req: RecordedRequest) -> Reply:
        name = schema_name(req)
        if overrides and name in overrides:
            return Reply.json(chat_answer(json.dumps(overrides[name])))
        shown = [step_of.get(hashlib.sha256(b).hexdigest()) for b in images(req)]
        if None in shown:
            return Reply.error(400, "the scripted model has not seen this frame")
        if name == "scene_graph":
            answer = scene_answer(shown[0])
        elif name == "actions":
            answer = actions_answer(shown[0], shown[1])
        else:
            answer = GOALS
        return Reply.json(chat_answer(json.dumps(answer)))

    return handle
