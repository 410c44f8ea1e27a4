"""``siftom listen`` (a microphone or a file as one), ``siftom ros`` (the ROS bridge) and
``siftom bench stream`` (end of speech to decision, false triggers on noise)."""

from __future__ import annotations

import dataclasses
import json
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from siftom.cli.records import pass_options
from siftom.errors import ObservationError, SiftomError

if TYPE_CHECKING:
    from siftom.listener import Compact, ListenEvent
    from siftom.speech.segment import Utterance

LIKELIHOOD_CHOICES = ("auto", "phonetic", "acoustic", "llm")


@dataclasses.dataclass(frozen=True)
class HomeFlags:
    """The flags of ``_home_options`` (the home, the model, the decision, the cutting) as one record."""

    scenario: str | None
    scene: str | None
    likelihood: str | None
    mode: str | None
    decide: str | None
    top: int | None
    config_file: Path | None
    threshold: float
    cost: float
    min_silence: float | None
    max_utterance: float


def _home_options(f: Any) -> Any:
    for opt in reversed([
        click.option("--scenario", "scenario", default=None, help="a registered scenario id (its world and goals)"),
        click.option("--scene", type=click.Path(exists=True, dir_okay=False), default=None,
                     help="a world JSON or VirtualHome scene graph file (docs/world.md)"),
        click.option("--likelihood", type=click.Choice(LIKELIHOOD_CHOICES), default=None,
                     help="the instruction likelihood (setting infer.likelihood, default auto: acoustic with the "
                          "whisper extra, scoring the utterance's audio itself, else phonetic)"),
        click.option("--mode", type=click.Choice(["full", "speech-only"]), default=None,
                     help="the model (setting model.mode, default full)"),
        click.option("--decide", default=None,
                     help="the decision rule (setting infer.decide, default teammate; docs/decisions.md)"),
        click.option("--top", type=click.IntRange(1, 20), default=None,
                     help="commands and goals in each answer (setting infer.top, default 10)"),
        click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="a TOML settings file (default: SIFTOM_CONFIG); flags > SIFTOM_* > file > defaults"),
        click.option("--threshold", type=click.FloatRange(0, 1), default=0.6, show_default=True,
                     help="ask when the best command's probability is below this (and asking pays)"),
        click.option("--cost", type=click.FloatRange(0, 1), default=0.1, show_default=True,
                     help="the price of asking, in chances of success"),
        click.option("--min-silence", type=click.FloatRange(0.05, 3), default=None,
                     help="seconds of silence that end an utterance (default 0.3)"),
        click.option("--max-utterance", type=click.FloatRange(1, 120), default=15.0, show_default=True,
                     help="speech longer than this is cut and answered"),
    ]):
        f = opt(f)
    return f


def _home_listener(home: HomeFlags, recorded: bool = True) -> Any:
    from siftom.assist.clarify import ClarifyPolicy
    from siftom.assist.decide import get_rule
    from siftom.listener import HomeListener, load_home
    from siftom.observer import observer_for
    from siftom.settings import Settings
    from siftom.speech.segment import SegmentOptions

    if home.decide is not None:
        get_rule(home.decide)  # an unknown name fails before any work
    observer = observer_for(Settings.load(home.config_file))
    opts: dict[str, Any] = {"max_utterance_s": home.max_utterance}
    if home.min_silence is not None:
        opts["min_silence_s"] = home.min_silence
        opts["post_roll_s"] = min(SegmentOptions().post_roll_s, home.min_silence)
    return HomeListener(load_home(home.scenario, home.scene), observer=observer, mode=home.mode,
                        likelihood=home.likelihood, top=home.top, decide=home.decide,
                        policy=ClarifyPolicy(home.threshold, home.cost), options=SegmentOptions(**opts),
                        recorded=recorded)


def _read_action_file(path: str) -> list[str]:
    p = Path(path)
    if not p.is_file():
        raise ObservationError(f"{path}: no such actions file; one action per line, or --actions - for stdin")
    return [ln.strip() for ln in p.read_text(encoding="utf-8").splitlines() if ln.strip() and not ln.startswith("#")]


def _stdin_actions(home: Any, say: Any) -> threading.Thread:
    """Observe action lines from stdin as they arrive (a bad line is reported, the rest go on)."""
    from siftom.listener import ActionsObserved, ListenerError

    def run() -> None:
        for line in sys.stdin:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            try:
                say(ActionsObserved(tuple(home.observe([line])), len(home.actions)), err=True)
            except SiftomError as exc:
                say(ListenerError(str(exc), line=line), err=True)

    t = threading.Thread(target=run, name="siftom-stdin-actions", daemon=True)
    t.start()
    return t


def _span(utt: Utterance | None) -> str:
    start, end = (round(utt.start_s, 3), round(utt.end_s, 3)) if utt is not None else (0.0, 0.0)
    return f"{start:6.2f}-{end:.2f} s"


def _decision_line(ev: dict[str, Any], span: str) -> str:
    """A decision event's line, from its JSON (what was heard, by whom, and what the robot does)."""
    scored = ev.get("likelihood") not in (None, "", "none")  # "none": no words reached a likelihood
    who = ", ".join(x for x in (ev.get("recogniser"), scored and f"likelihood {ev['likelihood']}",
                                ev.get("rule") and f"rule {ev['rule']}") if x)
    heard = f'heard "{ev.get("heard", "")}"' + (f" ({who})" if who else "")
    got = ev.get("decision")
    decision: dict[str, Any] = got if isinstance(got, dict) else {}
    if ev.get("action") == "act":
        does = f"carries out {ev.get('command')} (P = {float(ev.get('prob') or 0.0):.2f})"
    elif ev.get("action") == "ask":
        does = f'asks "{ev.get("question") or decision.get("question", "")}"'
    else:
        why = ev.get("message") or decision.get("reason", "")
        does = "does nothing" + (f" ({why})" if why else "")
    after = (ev.get("timings") or {}).get("after_speech_s")
    tail = f"  [{after:.2f} s after speech]" if isinstance(after, (int, float)) else ""
    return f"{span}  {heard}  ->  the robot {does}{tail}"


def human_line(ev: ListenEvent) -> str:
    """One readable line for a listener event (what ``siftom listen`` prints without ``--json``)."""
    from siftom.inference.stream import Decided, NoSpeech
    from siftom.listener import ActionsObserved
    from siftom.speech.segment import SpeechEnded, SpeechStarted

    if isinstance(ev, Decided):
        return _decision_line(ev.to_json(), _span(ev.utterance))
    if isinstance(ev, NoSpeech):
        heard = f' (the recogniser heard "{ev.heard}")' if ev.heard else ""
        return f"{_span(ev.utterance)}  {ev.message or 'no speech heard'}{heard}: nothing to answer"
    if isinstance(ev, SpeechStarted):
        return f"{round(ev.t, 3):6.2f} s    speech started"
    if isinstance(ev, SpeechEnded):
        return f"{_span(ev.utterance)}  speech ended ({ev.utterance.reason})"
    if isinstance(ev, ActionsObserved):
        added = ", ".join(ev.added) or "nothing"
        n = ev.n_actions
        return f"observed {added} ({n} action{'' if n == 1 else 's'} so far)"
    where = f"line {ev.line!r}" if ev.line is not None else \
        f"utterance {ev.utterance.index if ev.utterance is not None else '?'}"
    return f"error: {where}: {ev.detail}"


def _printer(as_json: bool = True) -> Any:
    """Print events: JSON lines (``as_json``) or one readable line each."""
    from siftom.listener import Compact

    lock = threading.Lock()

    def say(obj: ListenEvent | Compact, err: bool = False) -> None:
        with lock:
            click.echo(json.dumps(obj.to_json()) if as_json
                       else human_line(obj.event if isinstance(obj, Compact) else obj), err=err)
            (sys.stderr if err else sys.stdout).flush()

    return say


@dataclasses.dataclass(frozen=True)
class ListenFlags:
    """The ``siftom listen`` flags as one record."""

    mic: bool
    wav: str | None
    realtime: bool
    device: str | None
    seconds: float | None
    actions: str | None
    events: bool
    as_json: bool
    home: HomeFlags


@click.command("listen")
@click.option("--mic", is_flag=True, help="listen to the microphone (PortAudio through sounddevice)")
@click.option("--wav", type=click.Path(dir_okay=False), default=None, help="play this audio file as the microphone")
@click.option("--realtime", is_flag=True, help="with --wav: release the audio as fast as it was spoken")
@click.option("--device", default=None, help="with --mic: the input device (number or name)")
@click.option("--seconds", type=click.FloatRange(0.1, 86400), default=None,
              help="with --mic: stop after this long (default: Ctrl-C)")
@click.option("--actions", "actions", default=None,
              help="the person's actions: a file (one siftom or VirtualHome line each), or - to read lines "
                   "from stdin while listening")
@click.option("--events", is_flag=True, help="also print speech_started / speech_ended lines")
@click.option("--json", "as_json", is_flag=True,
              help="print one JSON line per event (for programs) instead of one readable line")
@_home_options
@pass_options(ListenFlags)
def listen_cmd(args: ListenFlags) -> None:
    """Listen like a robot: cut utterances out of a live stream and print one line per utterance:
    when it was said, what was heard (by which recogniser, scored by which likelihood, decided by
    which rule) and what the robot does. With --json, one JSON line each (the command, its
    probability, the posterior, timings).

    \b
    siftom listen --wav say.wav --realtime --scenario kitchen-cereal-v0
    tail -f actions.log | siftom listen --mic --scene world.json --actions - --json
    """
    from siftom.inference.stream import Decided, NoSpeech
    from siftom.listener import Compact, run_listener
    from siftom.speech.sources import file_chunks, mic_chunks

    mic, device = args.mic, args.device
    if mic == (args.wav is not None):
        raise ObservationError("give exactly one audio source: --mic or --wav FILE")
    if args.realtime and mic:
        raise ObservationError("--realtime is for --wav (a microphone is always real time)")
    say = _printer(args.as_json)
    chunks = mic_chunks(int(device) if device and device.isdigit() else device, seconds=args.seconds) if mic \
        else file_chunks(args.wav, realtime=args.realtime)  # type: ignore[arg-type]
    if mic:
        chunks = iter(chunks)
        first = next(chunks)  # open the device now: a missing PortAudio or device fails before loading
    # a scenario's recorded actions are observed first, unless --actions gives the person's own
    home = _home_listener(args.home, recorded=args.actions is None)
    _note_scoring(args.home.likelihood)
    if args.actions is not None and args.actions != "-":
        home.observe(_read_action_file(args.actions))
    elif args.actions == "-":
        _stdin_actions(home, say)
    if mic:
        import itertools

        chunks = itertools.chain([first], chunks)
        click.echo("listening… (Ctrl-C to stop)", err=True)
    try:
        run_listener(home, chunks, lambda ev: say(Compact(ev) if args.as_json and isinstance(ev, Decided | NoSpeech)
                                                  else ev), realtime=args.realtime or mic, events=args.events)
    except KeyboardInterrupt:
        pass
    finally:
        home.close()


def _note_scoring(likelihood: str | None) -> None:
    """Say on stderr what scores the speech when Whisper is missing, and the pip line that adds it."""
    from siftom.cli.inference import audio_likelihood_note

    note = audio_likelihood_note(likelihood)
    if note:
        click.echo(note, err=True)


@dataclasses.dataclass(frozen=True)
class RosFlags:
    """The ``siftom ros`` flags as one record."""

    url: str
    audio_topic: str
    audio_type: str
    text_topic: str
    text_type: str
    actions_topic: str
    actions_type: str
    decision_topic: str
    decision_type: str
    actions: str | None
    home: HomeFlags


@click.command("ros")
@click.option("--rosbridge", "url", required=True, help="the robot's rosbridge server, e.g. ws://robot.local:9090")
@click.option("--audio-topic", default="/audio/audio", show_default=True,
              help="microphone topic (16 kHz mono 16-bit PCM); '' to not subscribe")
@click.option("--audio-type", default="audio_common_msgs/AudioData", show_default=True)
@click.option("--text-topic", default="", help="a topic of recognised words (std_msgs/String) to answer too")
@click.option("--text-type", default="std_msgs/String", show_default=True)
@click.option("--actions-topic", default="/siftom/actions", show_default=True,
              help="the person's actions (std_msgs/String: siftom or VirtualHome script lines); '' for none")
@click.option("--actions-type", default="std_msgs/String", show_default=True)
@click.option("--decision-topic", default="/siftom/decision", show_default=True,
              help="where each decision is published (std_msgs/String holding JSON)")
@click.option("--decision-type", default="std_msgs/String", show_default=True)
@click.option("--actions", "actions", type=click.Path(exists=True, dir_okay=False), default=None,
              help="actions already seen before the bridge started (a file, one line each)")
@_home_options
@pass_options(RosFlags)
def ros_cmd(args: RosFlags) -> None:
    """Bridge to ROS through rosbridge: listen to the robot's microphone (and/or a text topic) and
    its perception of the person's actions; publish each decision on /siftom/decision.

    \b
    siftom ros --rosbridge ws://robot.local:9090 --scene home.json
    (docs/ros.md: launching rosbridge_server and audio_capture, remapping topics)
    """
    from siftom.service.ros import RosBridge, RosTopics, parse_url

    parse_url(args.url)  # a malformed URL fails before the model is built
    topics = RosTopics(audio=args.audio_topic, audio_type=args.audio_type, text=args.text_topic,
                       text_type=args.text_type, actions=args.actions_topic, actions_type=args.actions_type,
                       decision=args.decision_topic, decision_type=args.decision_type)
    home = _home_listener(args.home, recorded=args.actions is None)
    if args.audio_topic:
        _note_scoring(args.home.likelihood)
    if args.actions is not None:
        home.observe(_read_action_file(args.actions))
    say = _printer()
    bridge = RosBridge(home, args.url, topics, out=lambda obj: say(obj))
    click.echo(f"siftom ros: connected to {args.url}; publishing decisions on {topics.decision} (Ctrl-C to stop)",
               err=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        bridge.stop()
    finally:
        home.close()


@click.command("stream")
@click.option("--likelihood", "likelihoods", multiple=True, type=click.Choice(LIKELIHOOD_CHOICES),
              help="likelihoods to time (repeat; default: phonetic and acoustic)")
@click.option("--bed", default="", help="a recorded noise clip under the instructions, e.g. fan_01 (default: none)")
@click.option("--snr", type=float, default=10.0, show_default=True, help="the bed's SNR in dB")
@click.option("--noise-seconds", type=click.FloatRange(0, 3600), default=60.0, show_default=True,
              help="seconds each recorded noise clip is streamed for false triggers (0: skip)")
@click.option("--noise-clip", "noise_clips", multiple=True, help="only these noise clips (stems; repeat)")
@click.option("--seed", type=int, default=2, show_default=True, help="pauses between instructions, the bed's offset")
@click.option("--quick", is_flag=True, help="4 instructions, one noise clip per category")
@click.option("--json", "as_json", is_flag=True, help="print the result as JSON")
def bench_stream_cmd(likelihoods: tuple[str, ...], bed: str, snr: float, noise_seconds: float,
                     noise_clips: tuple[str, ...], seed: int, quick: bool, as_json: bool) -> None:
    """Stream spoken instructions in real time: end of speech -> decision (p50, p90) per likelihood,
    utterances cut or merged; then false triggers on the recorded noise clips (docs/streaming.md)."""
    from siftom.bench.stream import StreamBenchOptions, run_stream_bench

    opts = StreamBenchOptions(likelihoods=likelihoods or ("phonetic", "acoustic"), bed=bed, snr_db=snr,
                              noise_s=noise_seconds, noise_clips=noise_clips, seed=seed, quick=quick)
    res = run_stream_bench(opts)
    if as_json:
        click.echo(json.dumps({**res.to_json(), "meets_target": res.meets()}, indent=2))
        return
    click.echo(f"{len(res.utterances)} instructions in {res.stream_s:g} s of stream (bed: {bed or 'none'}), "
               "streamed in real time in 20 ms chunks")
    for lk, r in res.likelihoods.items():
        p50 = "-" if r["p50_s"] is None else f"{r['p50_s']:.3f} s"
        p90 = "-" if r["p90_s"] is None else f"{r['p90_s']:.3f} s"
        heard = sum(1 for u in r["utterances"] if u.get("command"))
        click.echo(f"{lk:9s} end of speech -> decision p50 {p50}, p90 {p90} ({r['answered']} answered); "
                   f"cut {r['cut_share']:.0%}, merged {r['merged_share']:.0%}, missed {r['missed']}; "
                   f"{heard} with a command")
    if res.noise:
        segs = sum(n["segments"] for n in res.noise)
        click.echo(f"noise: {len(res.noise)} clips x {noise_seconds:g} s: {res.false_triggers} false triggers "
                   f"(decisions), {segs} utterances cut in all")
        for n in res.noise:
            if n["segments"]:
                click.echo(f"  {n['clip']}: {n['segments']} cut, {n['decisions']} answered {n['heard']}")
    verdict = "meets" if res.meets() else "MISSES"
    click.echo(f"{verdict} the target: acoustic p50 <= 0.6 s and no false trigger")


def register(root: click.Group) -> None:
    """Add ``listen`` and ``ros`` to the root group, ``stream`` to ``bench``."""
    root.add_command(listen_cmd)
    root.add_command(ros_cmd)
    bench = root.commands.get("bench")
    if bench is None:
        bench = click.Group("bench", help="Benchmarks (speed and accuracy); --json for machines.")
        root.add_command(bench)
    if not isinstance(bench, click.Group):
        raise SiftomError("the 'bench' command is not a group; cannot add 'bench stream'")
    bench.add_command(bench_stream_cmd)
