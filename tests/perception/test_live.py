"""The whole chain with a real vision model: rendered kitchen-cereal-v0 frames -> world, actions -> infer.

Runs only where a real endpoint is configured: ``SIFTOM_LLM_BASE_URL`` and ``SIFTOM_VLM_MODEL``
(e.g. a llama.cpp server or vLLM serving a vision model, docs/perception.md)::

    SIFTOM_LLM_BASE_URL=http://127.0.0.1:8080/v1 SIFTOM_VLM_MODEL=qwen2.5-vl-7b \\
        pytest -m vlm -s tests/perception/test_live.py

``SIFTOM_VLM_STEPS`` picks the frames (default every step, 0..10). The report (objects and
actions recovered against the scenario's ground truth) is printed and written to
``$SIFTOM_VLM_REPORT`` when set.
"""

from __future__ import annotations

import json
import os
from collections import Counter

import pytest

from perception.ideal import SCENARIO, render_frames
from siftom.perception import Frame, perceive
from siftom.scenarios.base import get_scenario

pytestmark = [
    pytest.mark.vlm,
    pytest.mark.skipif(not (os.environ.get("SIFTOM_LLM_BASE_URL") and os.environ.get("SIFTOM_VLM_MODEL")),
                       reason="needs a real vision model: set SIFTOM_LLM_BASE_URL and SIFTOM_VLM_MODEL"),
]


def _lcs(a: list[str], b: list[str]) -> int:
    """Length of the longest common subsequence: actions recovered in the right order."""
    row = [0] * (len(b) + 1)
    for x in a:
        prev = 0
        for j, y in enumerate(b, 1):
            prev, row[j] = row[j], prev + 1 if x == y else max(row[j], row[j - 1])
    return row[-1]


def test_real_model_recovers_the_cereal_story(tmp_path):
    steps = tuple(int(s) for s in os.environ.get("SIFTOM_VLM_STEPS", ",".join(map(str, range(11)))).split(","))
    paths = render_frames(tmp_path, steps)
    sc = get_scenario(SCENARIO)
    res = perceive([Frame.from_path(p) for p in paths], goal_space="kitchen-v0")
    truth_objects = Counter((it.cls, sc.world.places[sc.start.item_at[k]].name) for k, it in enumerate(sc.world.items))
    seen_objects = Counter((it["class"], it["at"]) for it in res.world["items"])
    truth_actions = [sc.world.format_action(a) for a in sc.actions[: steps[-1]]][steps[0]:]
    from helpers import model_for
    from siftom.api import make_instruction
    from siftom.inference.model import Observation
    from siftom.world.io import scene_from_json
    from siftom.world.model import apply

    scene = scene_from_json(res.world)
    acts, s = [], scene.start
    for text in res.actions:
        acts.append(scene.world.parse_action(text, s))
        s = apply(s, acts[-1])
    post = model_for().infer(Observation(scene.world, scene.start, tuple(acts), scene.goals, scene.verb,
                                         make_instruction("can you pass me the silver")))
    report = {
        "model": os.environ["SIFTOM_VLM_MODEL"], "frames": list(steps),
        "objects": {"truth": sum(truth_objects.values()), "perceived": len(res.world["items"]),
                    "recovered_class_and_place": sum((truth_objects & seen_objects).values())},
        "actions": {"truth": len(truth_actions), "perceived": len(res.actions),
                    "recovered_in_order": _lcs(truth_actions, list(res.actions))},
        "goals": {"proposed": len(res.proposed_goals), "total": len(res.world["goals"])},
        "command": post.command, "requests": res.requests,
    }
    print(json.dumps(report, indent=2))
    if os.environ.get("SIFTOM_VLM_REPORT"):
        with open(os.environ["SIFTOM_VLM_REPORT"], "w", encoding="utf-8") as fh:
            json.dump(report, fh, indent=2)
    assert post.command.startswith("fetch(")  # the chain ran end to end; the numbers above are the result
