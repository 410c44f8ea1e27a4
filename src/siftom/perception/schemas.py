"""The JSON schemas sent with each request (structured output) and checked on each answer.

The schemas follow OpenAI's strict structured-output rules (every property required, no
additional properties), which vLLM, llama.cpp server and Ollama also accept, so a server that
constrains decoding produces a schema-valid answer; a server that does not is still checked
here. Schema-valid is not yet valid: ids, names and legality are checked against the scene by
:mod:`siftom.perception.validate`.
"""

from __future__ import annotations

from typing import Any

from siftom.errors import PerceptionError
from siftom.world.scenegraph import Relation

_VEC3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}

NODE_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "id": {"type": "integer"},
        "class_name": {"type": "string", "minLength": 1},
        "category": {"type": "string"},
        "properties": {"type": "array", "items": {"type": "string"}},
        "states": {"type": "array", "items": {"type": "string"}},
        "bounding_box": {
            "type": "object",
            "properties": {"center": _VEC3, "size": _VEC3},
            "required": ["center", "size"],
            "additionalProperties": False,
        },
    },
    "required": ["id", "class_name", "category", "properties", "states", "bounding_box"],
    "additionalProperties": False,
}

SCENE_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "nodes": {"type": "array", "items": NODE_SCHEMA, "minItems": 1},
        "edges": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "from_id": {"type": "integer"},
                    "relation_type": {"type": "string", "enum": [r.value for r in Relation]},
                    "to_id": {"type": "integer"},
                },
                "required": ["from_id", "relation_type", "to_id"],
                "additionalProperties": False,
            },
        },
    },
    "required": ["nodes", "edges"],
    "additionalProperties": False,
}

ACTIONS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {"actions": {"type": "array", "items": {"type": "string", "minLength": 1}}},
    "required": ["actions"],
    "additionalProperties": False,
}

GOALS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "target": {"type": "string", "minLength": 1},
        "goals": {
            "type": "array",
            "minItems": 1,
            "items": {
                "type": "object",
                "properties": {
                    "name": {"type": "string", "minLength": 1},
                    "counts": {
                        "type": "array",
                        "minItems": 1,
                        "items": {
                            "type": "object",
                            "properties": {"class": {"type": "string", "minLength": 1},
                                           "count": {"type": "integer", "minimum": 1}},
                            "required": ["class", "count"],
                            "additionalProperties": False,
                        },
                    },
                },
                "required": ["name", "counts"],
                "additionalProperties": False,
            },
        },
    },
    "required": ["target", "goals"],
    "additionalProperties": False,
}

SCHEMAS = {"scene_graph": SCENE_SCHEMA, "actions": ACTIONS_SCHEMA, "goals": GOALS_SCHEMA}


def check_schema(answer: Any, name: str) -> None:
    """Raise PerceptionError naming the first place where ``answer`` breaks schema ``name``."""
    try:
        import jsonschema
    except ImportError:  # pragma: no cover - a core dependency
        from siftom.errors import missing_extra

        raise missing_extra("vision", "jsonschema") from None
    validator = jsonschema.Draft202012Validator(SCHEMAS[name])
    errors = sorted(validator.iter_errors(answer), key=lambda e: (len(e.path), list(map(str, e.path))))
    if errors:
        first = errors[0]
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first.path).lstrip(".") or "the answer"
        more = f" (and {len(errors) - 1} more problems)" if len(errors) > 1 else ""
        raise PerceptionError(f"schema violation at {where}: {first.message}{more}")
