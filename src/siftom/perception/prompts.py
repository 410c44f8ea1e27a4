"""The prompts: one system message and one user message per question (scene, actions, goals).

Each user message states the output format in words as well as through the JSON schema, so a
server that ignores ``response_format`` still has a fair chance. docs/perception.md shows them.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import TYPE_CHECKING

from siftom.world.model import AGENT_NAMES, State, World

if TYPE_CHECKING:
    from siftom.perception.validate import NamedGoal
    from siftom.world.scenegraph import SceneGraph

SYSTEM = ("You are the eyes of a household robot. You turn camera images into symbols: scene graphs, "
          "action logs and goals. Answer with one JSON object that matches the given schema, nothing else.")

SCENE = """\
Describe the scene in this image as a VirtualHome scene graph.

Nodes: every room (category "Rooms", e.g. class_name "kitchen"), every piece of furniture that holds
objects or where someone stands (tables, counters, shelves: property "SURFACES"; fridges, cabinets,
drawers: properties "CONTAINERS" and "CAN_OPEN" and state "OPEN" or "CLOSED"), every movable object
(property "GRABBABLE"; one node per object, so two bowls are two nodes), the person (class_name
"character") and the robot (class_name "robot") if you see them. Use lower-case class names, with "_"
between words, as written in the image when it labels things. Ids are integers, unique in the graph.
bounding_box: centre and size in metres; x and z are the floor plan's axes, y is up.

Edges ("from_id RELATION to_id"): furniture INSIDE its room; each object ON the surface or INSIDE the
container it is on or in; the person and the robot CLOSE to the furniture they stand at. Relations:
ON, INSIDE, CLOSE, FACING, BETWEEN, HOLDS_RH, HOLDS_LH, SITTING.
"""

ACTIONS = """\
The first image shows the scene before, the second after. What did the person do in between?

The scene before the first image, in words:
{state}

Give the person's actions in order, one string each, in this syntax, using only the names above:
  walk(human, PLACE)            open(human, CONTAINER)      close(human, CONTAINER)
  grab(human, OBJECT, PLACE)    put(human, OBJECT, PLACE)   handover(human, OBJECT, robot)
The person carries one object at a time, must stand at a place to open, grab or put there, and
must open a closed container before taking from it. Give an empty list if nothing changed.
"""

GOALS = """\
The person is working towards a goal: gathering some objects on one place.

The scene, in words:
{state}

What the person has done so far:
{actions}

Propose up to {max_goals} plausible goals. Each goal has a short snake_case name and counts: how many
objects of each class must end up on the target place. Use only these object classes: {classes}.
target: the place where the person gathers things (one of the places above).{library}
"""


def describe_state(world: World, state: State) -> str:
    """Places with their room, door state and contents; where the agents are and what they hold."""
    lines = []
    for k, p in enumerate(world.places):
        objs = [world.items[i].name for i, at in enumerate(state.item_at) if at == k]
        door = "" if not p.closable else (" (open)" if state.is_open(k) else " (closed)")
        lines.append(f"- {p.name}: {p.kind} in the {p.room}{door}; holds {', '.join(objs) or 'nothing'}")
    for a, name in enumerate(AGENT_NAMES):
        held = state.held[a]
        hand = f", holding {world.items[held].name}" if held >= 0 else ""
        lines.append(f"- the {name} stands at {world.places[state.agent_at[a]].name}{hand}")
    return "\n".join(lines)


def scene_prompt(classes: Sequence[str] = (), previous: SceneGraph | None = None) -> str:
    """The scene question; ``classes`` are a goal library's object names to prefer."""
    text = SCENE
    if classes:
        text += f"\nWhen an object is one of these, use exactly this class name: {', '.join(sorted(classes))}.\n"
    if previous is not None:
        text += ("\nThe scene graph seen before (keep the ids of the things you see again):\n"
                 + json.dumps(previous.to_json(), separators=(",", ":")) + "\n")
    return text


def actions_prompt(world: World, state: State) -> str:
    return ACTIONS.format(state=describe_state(world, state))


def goals_prompt(world: World, state: State, actions: Sequence[str], library: Sequence[NamedGoal] = (),
                 max_goals: int = 10) -> str:
    examples = ""
    if library:
        shown = [f"{g.name}: " + ", ".join(f"{n} {c}" for c, n in g.counts) for g in library[:5]]
        examples = "\nGoals people in this kind of home often have (you may propose others):\n  " + "\n  ".join(shown)
    return GOALS.format(state=describe_state(world, state),
                        actions="\n".join(f"{k + 1}. {a}" for k, a in enumerate(actions)) or "(nothing yet)",
                        max_goals=max_goals, classes=", ".join(world.classes), library=examples)
