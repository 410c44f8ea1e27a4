"""People in the loop: ``collect`` (record instructions), ``annotate`` (the human baseline),
``dataset mix`` (noisy copies of recordings)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from siftom.cli.records import pass_options
from siftom.cli.service import with_access_options
from siftom.errors import DatasetError
from siftom.private import private_dir, private_umask

if TYPE_CHECKING:
    from siftom.service.access import Access


def _consent(path: str | None, default: str) -> str:
    if path is None:
        return default
    try:
        return Path(path).read_text(encoding="utf-8").strip()
    except (OSError, UnicodeDecodeError) as exc:
        raise DatasetError(f"cannot read the consent text {path!r} ({exc.__class__.__name__}); give a UTF-8 text file") from None


def _access(host: str, token: str | None, token_file: Path | None, allow_host: tuple[str, ...],
            allow_origin: tuple[str, ...]) -> tuple[Access, bool]:
    """The page's Host, Origin and token checks (a token whenever it listens beyond loopback) and
    whether the token was made here."""
    from siftom.cli.service import _need_serve_extra, access_for, resolve_token

    _need_serve_extra()
    private_umask()  # recordings, consent and answers: 0600 files in 0700 folders
    tok, generated = resolve_token(host, token, token_file)
    access: Access = access_for(host, tok, allow_host, allow_origin)
    return access, generated


def _serve(app: Any, host: str, port: int, what: str, access: Access, generated: bool) -> None:
    import uvicorn

    from siftom.cli.service import announce

    if host not in ("127.0.0.1", "localhost", "::1"):
        click.echo("note: browsers allow the microphone only on localhost or over https", err=True)
    announce(what, host, port, access.token, generated, " (Ctrl-C to stop)")
    uvicorn.run(app, host=host, port=port, log_level="warning", proxy_headers=False)  # X-Forwarded-For: not believed


_host = click.option("--host", default="127.0.0.1", show_default=True,
                     help="interface to listen on (loopback: nothing leaves the machine)")


@dataclasses.dataclass(frozen=True)
class CollectFlags:
    """The ``siftom collect`` flags as one record."""

    domain: str
    out: str
    scenarios: int
    participant: str | None
    new_key: bool
    consent: str | None
    max_seconds: float
    host: str
    port: int
    token: str | None
    token_file: Path | None
    allow_host: tuple[str, ...]
    allow_origin: tuple[str, ...]


@click.command("collect")
@click.option("--domain", default="household-table-v0", show_default=True, help="household-table-v0 | kitchen-v0")
@click.option("--out", "out", type=click.Path(file_okay=False), required=True,
              help="dataset folder to record into (created; more participants add to it)")
@click.option("--scenarios", type=click.IntRange(1, 10_000), default=26, show_default=True,
              help="scenarios per participant (registered first, then generated)")
@click.option("--participant", default=None, help="participant id (default: asked on the page)")
@click.option("--new-key", is_flag=True,
              help="with --participant: the participant's old key stops working and their next agreement "
                   "on this page gets a new one (for a participant who lost their page)")
@click.option("--consent", "consent", type=click.Path(dir_okay=False), default=None,
              help="a text file with the consent text to show (default: a generic one)")
@click.option("--max-seconds", type=click.FloatRange(1, 120), default=30.0, show_default=True,
              help="longest recording accepted")
@_host
@click.option("--port", type=click.IntRange(1, 65535), default=8010, show_default=True, help="TCP port")
@with_access_options
@pass_options(CollectFlags)
def collect_cmd(args: CollectFlags) -> None:
    """Serve a page that records participants asking the robot for help, into a dataset folder.

    Each participant agrees to the consent text, then sees each scenario (the scene after each of
    the person's actions and the goal in words), records what they would ask the robot and types
    what they said. Then: siftom dataset mix OUT, siftom dataset check OUT, siftom eval. With
    --participant the page records that participant only; --new-key also resets their key when
    they lost their page (without it, only the page holding the key can go on). Beyond loopback
    the page needs a token, as siftom serve does.
    """
    from siftom.bench.runlock import RunLock
    from siftom.people.collect import CONSENT_TEXT, CollectOptions
    from siftom.service.collect_app import create_collect_app

    if args.new_key and args.participant is None:
        raise click.UsageError("--new-key resets one participant's key: give --participant ID too")
    opts = CollectOptions(domain=args.domain, scenarios=args.scenarios, participant=args.participant,
                          consent=_consent(args.consent, CONSENT_TEXT), max_seconds=args.max_seconds)
    access, generated = _access(args.host, args.token, args.token_file, args.allow_host, args.allow_origin)
    private_dir(args.out)
    with RunLock(args.out):  # one server per folder: several participants may share it, two servers may not
        app = create_collect_app(args.out, opts, access)
        if args.new_key and args.participant is not None:
            if app.state.collection.reset_key(args.participant):
                click.echo(f"siftom: {args.participant}'s old key no longer works; their next agreement on this page "
                           "gets a new one", err=True)
            else:
                click.echo(f"siftom: {args.participant} has no key yet (they have not agreed); nothing to reset",
                           err=True)
        _serve(app, args.host, args.port, f"recording page for {args.out}", access, generated)


@dataclasses.dataclass(frozen=True)
class AnnotateFlags:
    """The ``siftom annotate`` argument and flags as one record."""

    dataset: str
    out: str
    per_stimulus: int
    per_annotator: int | None
    seed: int
    consent: str | None
    host: str
    port: int
    token: str | None
    token_file: Path | None
    allow_host: tuple[str, ...]
    allow_origin: tuple[str, ...]


@click.command("annotate")
@click.argument("dataset", type=click.Path(file_okay=False))
@click.option("--out", "out", type=click.Path(file_okay=False), required=True,
              help="annotation folder (plan.json, answers.jsonl; resumes if it exists)")
@click.option("--per-stimulus", type=click.IntRange(1, 1000), default=3, show_default=True,
              help="annotators per stimulus")
@click.option("--per-annotator", type=click.IntRange(1, 100_000), default=None,
              help="stimuli per annotator (default: every stimulus once)")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="seed of the order and the assignments")
@click.option("--consent", "consent", type=click.Path(dir_okay=False), default=None,
              help="a text file with the consent text to show (default: a generic one)")
@_host
@click.option("--port", type=click.IntRange(1, 65535), default=8011, show_default=True, help="TCP port")
@with_access_options
@pass_options(AnnotateFlags)
def annotate_cmd(args: AnnotateFlags) -> None:
    """Serve the human-baseline page: people hear each stimulus, type it and choose what to bring.

    Score the answers next to the models with: siftom report RESULTS --human OUT (RESULTS: siftom
    eval --dataset DATASET --out RESULTS).
    """
    from siftom.people.annotate import ANNOTATOR_CONSENT, AnnotateOptions
    from siftom.service.annotate_app import create_annotate_app

    opts = AnnotateOptions(per_stimulus=args.per_stimulus, per_annotator=args.per_annotator, seed=args.seed,
                           consent=_consent(args.consent, ANNOTATOR_CONSENT))
    from siftom.bench.runlock import RunLock

    access, generated = _access(args.host, args.token, args.token_file, args.allow_host, args.allow_origin)
    private_dir(args.out)
    with RunLock(args.out):
        app = create_annotate_app(args.dataset, args.out, opts, access)
        _serve(app, args.host, args.port, f"annotation page ({len(app.state.annotation.assignments)} assignments)",
               access, generated)


@click.command("mix")
@click.argument("folder", type=click.Path(file_okay=False))
@click.option("--noise-dir", type=click.Path(file_okay=False), default=None,
              help="folder of noise WAVs named CATEGORY_NN.wav (default: the recordings shipped with siftom)")
@click.option("--noises", default=None, help="comma-separated categories of the noise folder (default: all)")
@click.option("--snr", "snr", default="20,10,5", show_default=True, help="one noisy copy per SNR (dB)")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="seed of the noise excerpts")
@click.option("--json", "as_json", is_flag=True, help="print a JSON summary")
def mix_cmd(folder: str, noise_dir: str | None, noises: str | None, snr: str, seed: int, as_json: bool) -> None:
    """Add noisy copies of every clean recording in a dataset FOLDER (clean + noisy: 130 -> 520)."""
    from siftom.bench.mix import MixOptions, mix_dataset
    from siftom.cli.audio_out import FOLDER_FIX, writing_audio
    from siftom.cli.bench import _csv, _snrs

    opts = MixOptions(noise_dir=noise_dir, noises=_csv(noises), snrs=_snrs(snr), seed=seed)
    with writing_audio(folder, "the noisy copies into", fix=FOLDER_FIX):
        ds, written = mix_dataset(folder, opts)
    clean = sum(1 for s in ds.stimuli if s.noise is None)
    if as_json:
        click.echo(json.dumps({"out": str(ds.root), "stimuli": len(ds.stimuli), "clean": clean, "mixed": written}))
    else:
        click.echo(f"{written} noisy copies of {clean} clean recordings; {ds.root} now holds {len(ds.stimuli)} stimuli")


def register(root: click.Group) -> None:
    """Add ``collect``, ``annotate`` and ``dataset mix``."""
    root.add_command(collect_cmd)
    root.add_command(annotate_cmd)
    dataset = root.commands.get("dataset")
    if isinstance(dataset, click.Group):
        dataset.add_command(mix_cmd)
