"""``siftom infer`` and the inference/planner benchmarks (``siftom bench inference|planner``)."""

from __future__ import annotations

import json
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from siftom.assist.decide import RULES
from siftom.backends.cli_options import flags_given, llm_config, llm_options
from siftom.errors import ObservationError
from siftom.likelihood.registry import LIKELIHOODS
from siftom.safejson import loads, read_text
from siftom.speech.asr.base import ENGINES
from siftom.speech.cli_options import whisper_model_option


def _bench_group(root: click.Group) -> click.Group:
    bench = root.commands.get("bench")
    if bench is None:
        bench = click.Group("bench", help="Benchmarks (speed and accuracy); --json for machines.")
        root.add_command(bench)
    return bench  # type: ignore[return-value]


def _read_actions(path: Path) -> list[str]:
    text = read_text(path, "actions file")
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    except (RecursionError, ValueError):  # JSON nested too deeply, or an integer too long to read
        data = loads(text, f"actions file {str(path)!r}")
    if isinstance(data, dict):
        data = data.get("actions")
    if not isinstance(data, list) or not all(isinstance(a, str) for a in data):
        raise ObservationError(f"{path}: give a JSON list of action strings (or one action per line)")
    return data


def _unmentioned(path: Path, scene, goal_space: str | None) -> list[str]:  # noqa: ANN001
    """Warnings for object classes no goal mentions (each naming the nearest library classes)."""
    from siftom.world.io import scene_warnings

    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if goal_space and isinstance(obj, dict) and "goals" not in obj:
        obj = {**obj, "goal_space": goal_space}
    return scene_warnings(obj, scene)


def _read_nbest(path: Path) -> list[dict]:
    try:
        data = loads(read_text(path, "N-best file"), f"N-best file {str(path)!r}")
    except ObservationError as exc:
        raise ObservationError(f"{exc}; write the output of `siftom transcribe --json`") from None
    if isinstance(data, dict):
        data = data.get("nbest")
    if not isinstance(data, list) or not data:
        raise ObservationError(f"{path}: expected a non-empty list of {{text, score}} (or {{'nbest': [...]}})")
    return data


@click.command("infer")
@whisper_model_option
@click.option("--scenario", "scenario_id", default=None, help="A registered scenario id (see `siftom scenarios list`).")
@click.option("--scene", "scene_file", type=click.Path(path_type=Path), default=None,
              help="Your own world JSON or VirtualHome graph (instead of --scenario).")
@click.option("--actions", "actions_file", type=click.Path(path_type=Path), default=None,
              help="The human's actions: JSON list or one per line, e.g. grab(human, milk, fridge) "
                   "or VirtualHome script lines, e.g. [Grab] <milk> (195).")
@click.option("--goal-space", default=None, help="For --scene: household-table-v0 or kitchen-v0.")
@click.option("--target", default=None, help="For a VirtualHome --scene: class name of the target surface.")
@click.option("--transcript", default=None, help="What was heard (1-best transcript).")
@click.option("--nbest", "nbest_file", type=click.Path(path_type=Path), default=None,
              help="JSON N-best list [{text, score}, ...] (e.g. from `siftom transcribe --json`).")
@click.option("--audio", type=click.Path(path_type=Path), default=None, help="A WAV file of the instruction.")
@click.option("--model", "mode", type=click.Choice(["full", "speech-only", "action-only"]), default="full")
@click.option("--likelihood", default=None,
              help=f"Instruction likelihood: {LIKELIHOODS.help_line()}. Default: acoustic for --audio when the "
                   "whisper extra is installed, else phonetic.")
@click.option("--engine", default="pocketsphinx", help=f"ASR engine for --audio: {ENGINES.help_line()}.")
@click.option("--png", type=click.Path(path_type=Path), default=None, help="Write the scene + posterior picture.")
@click.option("--decide", "rule", default="map", show_default=True,
              help=f"Decision rule: {RULES.help_line()} (docs/decisions.md).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@llm_options
def infer_cmd(scenario_id, scene_file, actions_file, goal_space, target, transcript, nbest_file, audio, mode,
              likelihood, engine, png, rule, as_json, llm_backend, llm_base_url, llm_model) -> None:
    """Infer the goal and the robot command from what the human did and said.

    With --likelihood llm the language model comes from the --llm-* flags or SIFTOM_LLM_*.
    """
    from siftom.api import get_model, make_instruction
    from siftom.assist.decide import get_rule
    from siftom.inference.model import Observation

    decision_rule = get_rule(rule)  # an unknown name fails before any work
    llm = None
    if likelihood == "llm":
        llm = llm_config(llm_backend, llm_base_url, llm_model)
    elif flags_given(llm_backend, llm_base_url, llm_model):
        click.echo(f"note: the --llm-* flags only apply to --likelihood llm (not {likelihood or 'the default'})", err=True)

    if (scenario_id is None) == (scene_file is None):
        raise ObservationError("give exactly one of --scenario ID or --scene FILE")
    nbest = _read_nbest(nbest_file) if nbest_file else None
    if audio is not None and not nbest and transcript is None:
        _infer_audio(scenario_id, scene_file, actions_file, goal_space, target, audio, mode, likelihood, engine,
                     png, as_json)
        return
    from siftom.likelihood.registry import resolve_likelihood

    likelihood, _why = resolve_likelihood(likelihood, has_audio=False)  # a transcript: no sound to score
    instruction = make_instruction(transcript, nbest, audio)
    if instruction is None and mode != "action-only":
        raise ObservationError("give --transcript, --nbest or --audio (or use --model action-only)")
    model = get_model(mode, likelihood, llm)
    sc = None
    warnings: list[str] = []
    if scenario_id is not None:
        from siftom.scenarios.base import get_scenario

        sc = get_scenario(scenario_id)
        if actions_file is not None:
            from siftom.api import infer_actions

            post = infer_actions(scenario_id, _read_actions(actions_file), instruction, mode, likelihood, llm)
        else:
            post = model.infer(Observation.from_scenario(sc, instruction))
    else:
        from siftom.world.io import load_scene
        from siftom.world.vhscript import parse_actions

        scene = load_scene(scene_file, goal_space=goal_space, target=target)
        warnings = _unmentioned(scene_file, scene, goal_space)
        if not as_json:  # with --json they are a field of the output
            for w in warnings:
                click.echo(f"warning: {w}", err=True)
        acts, _ = parse_actions(scene.world, scene.start, _read_actions(actions_file) if actions_file else [],
                                first=1, label="action {k}")
        post = model.infer(Observation(scene.world, scene.start, tuple(acts), scene.goals, scene.verb, instruction))
    decision = None
    if post.joint is not None and post.joint.state is not None:
        from siftom.assist.decide import Situation

        world = sc.world if sc is not None else scene.world
        target = sc.target if sc is not None else scene.goals[0].target
        decision = decision_rule(post, Situation(world, post.joint.state, target))
    if png is not None and sc is not None:
        from siftom.world.render import render_scenario

        render_scenario(sc, png, posterior=post)
    if as_json:
        body = post.to_json()
        if decision is not None:
            body["decision"] = decision.to_json()
        if scene_file is not None:
            body["warnings"] = warnings
        click.echo(json.dumps(body, indent=2))
        return
    print_posterior(post)
    if decision is not None and rule != "map":
        Console().print(f"[bold]decision ({rule}):[/bold] "
                        + (f'ask "{decision.question}"' if decision.ask else decision.action)
                        + f" — {decision.reason}")


def _infer_audio(scenario_id, scene_file, actions_file, goal_space, target, audio, mode, likelihood, engine, png,
                 as_json) -> None:
    """``--audio``: one call to siftom.api.listen (VAD, recognition, likelihood, posterior)."""
    from siftom.api import listen

    actions = _read_actions(actions_file) if actions_file else None
    if scenario_id is not None:
        heard = listen(audio, scenario=scenario_id, actions=actions, mode=mode, likelihood=likelihood, engine=engine)
    else:
        from siftom.world.io import load_scene

        scene = load_scene(scene_file, goal_space=goal_space, target=target)
        heard = listen(audio, world=scene, actions=actions or [], mode=mode, likelihood=likelihood, engine=engine)
    if png is not None and scenario_id is not None:
        from siftom.scenarios.base import get_scenario
        from siftom.world.render import render_scenario

        render_scenario(get_scenario(scenario_id), png, posterior=heard.posterior)
    if as_json:
        click.echo(json.dumps(heard.to_json(), indent=2))
        return
    con = Console()
    if not heard.speech:
        con.print("[bold yellow]no speech heard[/bold yellow] in the recording: the posterior below comes from "
                  "the actions alone")
    elif not heard.instruction:
        con.print(f'[bold yellow]no instruction heard[/bold yellow]: "{heard.posterior.transcript}" holds no '
                  f"command of this scene ({heard.posterior.evidence.get('no_instruction_reason', '')}); no command "
                  "issued. The posterior below comes from the actions alone")
    print_posterior(heard.posterior, con)
    con.print(f"{heard.seconds * 1000:.0f} ms from the audio file to the command (a first call: it includes "
              "loading the recogniser and the scene; `siftom bench latency` times warm calls)")


def print_posterior(post, console: Console | None = None) -> None:
    """The readable table: top commands, goals and hypotheses with each term."""
    con = console or Console()
    if post.transcript:
        con.print(f'heard: "{post.transcript}"   model: {post.mode}, likelihood: {post.likelihood}, '
                  f"{post.n_actions} observed actions")
    if post.evidence.get("whisper_heard") is not None:
        use = {"carrier": "a second carrier: it placed the object words",
               "guesses": "no object word heard by either: guesses around its words"}.get(
            post.evidence.get("whisper_use", ""), "no object word in it: not used")
        con.print(f'Whisper heard: "{post.evidence["whisper_heard"]}" ({use})')
    if post.evidence.get("likelihood_reason"):
        con.print(f"likelihood {post.evidence['likelihood']}: {post.evidence['likelihood_reason']}")
    t = Table(title="robot commands")
    t.add_column("command")
    t.add_column("P", justify="right")
    for c, p in post.commands[:6]:
        t.add_row(c, f"{p:.3f}")
    g = Table(title="goals")
    g.add_column("goal")
    g.add_column("P", justify="right")
    for name, p in post.goals[:6]:
        g.add_row(name, f"{p:.3f}")
    h = Table(title="top hypotheses (log terms)")
    for col in ("goal", "command", "P", "prior", "actions", "words"):
        h.add_column(col, justify="right" if col not in ("goal", "command") else "left")
    for hy in post.hypotheses[:6]:
        h.add_row(hy.goal, hy.command, f"{hy.prob:.3f}", f"{hy.log_prior:.2f}", f"{hy.log_action:.2f}",
                  f"{hy.log_instruction:.2f}")
    con.print(t)
    con.print(g)
    con.print(h)
    con.print(f"[bold green]chosen command: {post.command}[/bold green]")


def register(root: click.Group) -> None:
    root.add_command(infer_cmd)
    from siftom.bench.speed import bench_inference_cmd, bench_planner_cmd

    bench = _bench_group(root)
    bench.add_command(bench_inference_cmd)
    bench.add_command(bench_planner_cmd)
    from siftom.bench.latency import bench_latency_cmd

    bench.add_command(bench_latency_cmd)
    from siftom.bench.calibrate import _cli as calibrate_cli

    bench.add_command(calibrate_cli())
    from siftom.bench.decide_speed import bench_decide_cmd

    bench.add_command(bench_decide_cmd)
    from siftom.bench.decisions import answer_reliability_cmd, ask_penalty_cmd

    bench.add_command(ask_penalty_cmd)
    bench.add_command(answer_reliability_cmd)
    from siftom.bench.answers import answer_grammar_cmd

    bench.add_command(answer_grammar_cmd)
    from siftom.bench.decision_tuning import loss_aversion_cmd

    bench.add_command(loss_aversion_cmd)
