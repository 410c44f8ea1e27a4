"""Perception: camera frames -> scene graph, the person's actions and a goal space, via a VLM.

``perceive(frames)`` asks an OpenAI-compatible vision-language model (docs/perception.md) and
returns siftom world JSON plus an action log that ``siftom infer --scene --actions`` reads.
"""

from siftom.perception.frames import Frame
from siftom.perception.pipeline import PerceptionResult, perceive, perceive_actions
from siftom.perception.vlm import VisionModel

__all__ = ["Frame", "PerceptionResult", "VisionModel", "perceive", "perceive_actions"]
