"""Top-down maps of scenarios drawn with matplotlib: rooms, furniture, objects, agents, paths."""

from __future__ import annotations

import textwrap
from collections import defaultdict
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyBboxPatch, Rectangle  # noqa: E402

from siftom.world.model import HELD, HUMAN, ROBOT, State, World  # noqa: E402

ROOM_COLOURS = ("#f3efe6", "#e8f1f8", "#eef6ea", "#f8ecef", "#f1ecf8", "#f8f5e6")


def _room_boxes(scenario: Any) -> dict[str, tuple[float, float, float, float]]:
    pts: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for p in scenario.world.places:
        pts[p.room].append(p.pos)
    boxes = {}
    for room, ps in pts.items():
        xs, ys = [x for x, _ in ps], [y for _, y in ps]
        boxes[room] = (min(xs) - 1.6, min(ys) - 1.6, max(xs) + 1.6, max(ys) + 1.6)
    return boxes


def render_scenario(scenario: Any, path: str | Path, posterior: Any = None, command: str | None = None,
                    title: str | None = None, show_path: bool = True, step: int | None = None,
                    doing: str | None = None) -> Path:
    """Draw ``scenario`` (state when the human spoke) to a PNG; optionally a posterior bar chart.

    Args:
        posterior: a Posterior; its top commands are drawn beside the map.
        command: a command to highlight (objects of its class are ringed).
        doing: what the robot does (``Answer.doing``), written above the chart; without it the
            chart names the posterior's most probable command, which the robot may not act on.
        show_path: draw the human's observed walking trajectory.
        step: draw the state after this many observed actions (default: all of them), e.g.
            the frames a camera would have seen (``siftom scenarios show ID --step K``); object
            lists are then wrapped instead of shortened, so every object can be read.
    """
    states = scenario.states()
    if step is not None:
        if not 0 <= step < len(states):
            from siftom.errors import ObservationError

            raise ObservationError(f"step must be between 0 and {len(states) - 1} for {scenario.id}, got {step}")
        states = states[: step + 1]
    ncols = 2 if posterior is not None else 1
    fig, axes = plt.subplots(1, ncols, figsize=(11 if ncols == 2 else 7.5, 6),
                             gridspec_kw={"width_ratios": [1.6, 1]} if ncols == 2 else None)
    ax = axes[0] if ncols == 2 else axes
    for k, (room, (x0, y0, x1, y1)) in enumerate(sorted(_room_boxes(scenario).items())):
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc=ROOM_COLOURS[k % len(ROOM_COLOURS)], ec="#888", lw=1))
        ax.text(x0 + 0.15, y1 - 0.2, room.replace("_", " "), fontsize=9, va="top", color="#555", style="italic")
    highlight = command or (posterior.command if posterior is not None else None)
    _draw_places(ax, scenario, states[-1], _class_of(scenario, highlight), step is not None)
    _draw_agents(ax, scenario.world, states, show_path)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.axis("off")
    ax.set_title(title or f"{scenario.id}: {scenario.description}", fontsize=9)
    if posterior is not None:
        _draw_posterior(axes[1], posterior, doing)
    fig.tight_layout()
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    # exactly ``path``: no suffix added to a name without one; the version that drew it in its metadata
    fig.savefig(out, dpi=110, format="png", metadata={"Software": f"siftom {_version()}"})
    plt.close(fig)
    return out


def _class_of(scenario: Any, command: Any) -> str | None:
    """The object class of the command to highlight (None: none, or not a command)."""
    if not command:
        return None
    try:
        cls: str = scenario.parse_command(command).obj_class
    except Exception:  # a free-form or invalid command: nothing to ring
        return None
    return cls


def _draw_places(ax: Any, scenario: Any, now: State, hl_cls: str | None, wrap: bool) -> None:
    """Each place with its name and the objects on it (those of ``hl_cls`` in red); ``wrap``:
    object lists are wrapped instead of shortened (a camera frame: every object must stay readable)."""
    w = scenario.world
    by_place: dict[int, list[int]] = defaultdict(list)
    for i, loc in enumerate(now.item_at):
        if loc != HELD:
            by_place[loc].append(i)
    for i, p in enumerate(w.places):
        x, y = p.pos
        target = i == scenario.target
        fc = "#ffd27f" if target else ("#c9b79c" if p.closable else "#d9d0c1")
        ax.add_patch(FancyBboxPatch((x - 0.6, y - 0.35), 1.2, 0.7, boxstyle="round,pad=0.02", fc=fc,
                                    ec="#b8860b" if target else "#7a6a55", lw=2 if target else 1))
        state = "" if not p.closable else (" (open)" if now.is_open(i) else " (closed)")
        ax.text(x, y - 0.55, p.name.replace("_", " ") + state, ha="center", va="top", fontsize=6.5)
        items = by_place.get(i, [])
        counts: dict[str, int] = defaultdict(int)
        for it in items:
            counts[w.items[it].cls] += 1
        label = ", ".join(f"{n}×{c}" if n > 1 else c for c, n in sorted(counts.items()))
        if wrap:
            import textwrap

            label = "\n".join(textwrap.wrap(label, 44))
        elif len(label) > 42:
            label = label[:40] + "…"
        if label:
            ring = hl_cls is not None and hl_cls in counts
            ax.text(x, y + 0.45, label, ha="center", va="bottom", fontsize=6,
                    color="#b00020" if ring else "#222", weight="bold" if ring else "normal")


def _draw_agents(ax: Any, w: World, states: list[State], show_path: bool) -> None:
    """The human's walking trajectory (``show_path``), both agents and what they hold."""
    now = states[-1]
    if show_path and len(states) > 1:
        xs = [w.places[s.agent_at[HUMAN]].pos[0] for s in states]
        ys = [w.places[s.agent_at[HUMAN]].pos[1] for s in states]
        ax.plot(xs, ys, "-", color="#1f77b4", alpha=0.5, lw=2, zorder=3)
    for agent, colour, dy in ((HUMAN, "#1f77b4", 0.0), (ROBOT, "#d62728", 0.25)):
        x, y = w.places[now.agent_at[agent]].pos
        ax.plot([x + 0.75], [y + dy], "o", ms=11, color=colour, zorder=5)
        ax.text(x + 0.75, y + dy, "H" if agent == HUMAN else "R", color="white", ha="center", va="center",
                fontsize=7, weight="bold", zorder=6)
        if now.held[agent] >= 0:
            ax.text(x + 1.0, y + dy, f"holds {w.items[now.held[agent]].cls}", color=colour, va="center",
                    fontsize=6.5, zorder=6)


def _draw_posterior(bx: Any, posterior: Any, doing: str | None) -> None:
    """The posterior's top commands as a bar chart, the most probable one in green."""
    top = list(posterior.commands[:8])[::-1]
    names = [c for c, _ in top]
    probs = [p for _, p in top]
    colours = ["#2ca02c" if c == posterior.command else "#9ecae1" for c in names]
    bx.barh(names, probs, color=colours)
    bx.set_xlim(0, 1)
    bx.set_xlabel("P(command | actions, words)")
    heard = f'heard: "{posterior.transcript}"' if posterior.transcript else "no instruction"
    said = f"robot: {doing}" if doing is not None else f"most probable: {posterior.command}"
    bx.set_title(f"{heard}\n{textwrap.shorten(said, 60)}", fontsize=9)
    bx.tick_params(axis="y", labelsize=8)


def _version() -> str:
    """The installed siftom's version (read from its metadata: the world layer imports no door)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("siftom")
    except PackageNotFoundError:
        return "unknown"
