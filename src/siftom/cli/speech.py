"""Speech subcommands: ``say``, ``transcribe``, ``voices``, ``bench asr``, ``bench acoustic``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from siftom.cli.audio_out import SNR_MAX_DB, SNR_MIN_DB, WRITE_FIX, writing_audio
from siftom.errors import SiftomError
from siftom.speech.asr.base import ENGINES


def _vocab(spec: str | None) -> list[str] | None:
    """A vocabulary from a file (one phrasing per line) or comma-separated phrasings/words."""
    if spec is None:
        return None
    p = Path(spec)
    if p.is_file():
        from siftom.safejson import read_text

        items = [line.strip() for line in read_text(p, "--vocab file", SiftomError).splitlines()]
        items = [i for i in items if i and not i.startswith("#")]
    else:
        items = [s.strip() for s in spec.split(",") if s.strip()]
    if not items:
        raise SiftomError(f"--vocab {spec!r} gives no phrasings; use a file or 'cereal,milk'")
    return items


@click.command("say")
@click.argument("text")
@click.option("--voice", "-v", default="flite-slt", show_default=True, help="voice name (siftom voices)")
@click.option("--rate", type=float, default=1.0, show_default=True, help="speaking-rate multiplier")
@click.option("--pitch", type=float, default=1.0, show_default=True, help="pitch multiplier")
@click.option("--noise", default=None, help="white|pink|brown|babble|hum, recorded[:CATEGORY] (the shipped recordings), a WAV file or a folder of them")
@click.option("--snr", type=click.FloatRange(SNR_MIN_DB, SNR_MAX_DB), default=10.0, show_default=True,
              help="SNR in dB over active speech")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True, help="seed for the noise excerpt")
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True, help="output WAV")
def say_cmd(text: str, voice: str, rate: float, pitch: float, noise: str | None, snr: float,
            seed: int, output: str) -> None:
    """Speak TEXT with a voice, optionally mixed with noise at an SNR, to a 16 kHz WAV."""
    from siftom.speech.audio import duration_s, write_wav
    from siftom.speech.noise import get_noise, mix_at_snr
    from siftom.speech.tts import synthesize

    x = synthesize(text, voice, rate=rate, pitch=pitch)
    if noise is not None:
        x = mix_at_snr(x, get_noise(noise), snr, seed)
    with writing_audio(output, fix=f"give -o {WRITE_FIX}"):
        path = write_wav(output, x)
    extra = f", {noise} at {snr:g} dB" if noise else ""
    click.echo(f"wrote {path} ({duration_s(x):.2f} s, {voice}{extra})")


@click.command("transcribe")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--engine", "-e", default="pocketsphinx", show_default=True, help=f"ASR engine: {ENGINES.help_line()}")
@click.option("--nbest", "-n", type=int, default=1, show_default=True, help="hypotheses to return")
@click.option("--vocab", default=None, help="pocketsphinx engines: phrasings file, or comma-separated words/phrasings")
@click.option("--model-dir", default=None, help="whisper: a local CTranslate2 whisper folder")
@click.option("--vad/--no-vad", default=True, show_default=True,
              help="detect speech first: silence or noise alone gives 'no speech heard', not words")
@click.option("--json", "as_json", is_flag=True, help="print JSON: text, nbest [{text, score}], words, rtf, vad")
def transcribe_cmd(file: str, engine: str, nbest: int, vocab: str | None, model_dir: str | None,
                   vad: bool, as_json: bool) -> None:
    """Recognise the speech in FILE (any rate/channels; resampled to 16 kHz mono).

    With the voice-activity detector (default) a recording with no speech prints
    "no speech heard" (JSON: ``"no_speech": true``, empty ``text`` and ``nbest``) instead of
    the words a recogniser hallucinates from noise; speech is cut to its regions first.
    """
    from siftom.speech.asr.base import get_engine, is_scene_engine
    from siftom.speech.audio import load_audio

    if vocab is None and is_scene_engine(engine):
        raise SiftomError(f"--engine {engine} is built from the command phrasings it listens for: give them "
                          "with --vocab FILE (one phrasing per line) or --vocab 'pass me the cereal,milk'")
    x = load_audio(file)  # validate before loading a model
    opts: dict[str, Any] = {}
    if vocab is not None:
        if not engine.startswith("pocketsphinx"):
            raise SiftomError("--vocab applies to the pocketsphinx engines only (pocketsphinx, -vocab, -open, -dual)")
        opts["vocabulary"] = _vocab(vocab)
    if model_dir is not None:
        if engine != "whisper":
            raise SiftomError("--model-dir applies to --engine whisper only")
        opts["model_dir"] = model_dir
    asr = get_engine(engine, **opts)
    found = None
    if vad:
        from siftom.speech.vad import detect_speech, trim

        found = detect_speech(x)
        if not found.speech:
            if as_json:
                click.echo(json.dumps({"text": "", "nbest": [], "no_speech": True, "engine": engine,
                                       "vad": found.to_json()}, indent=2))
            else:
                click.echo(f"no speech heard ({found.duration_s:.2f} s of audio; --no-vad to transcribe anyway)",
                           err=True)
            return
        x = trim(x, found)
    tr = asr.transcribe(x, nbest=nbest)
    if as_json:
        out = tr.to_json()
        if found is not None:
            out.update(no_speech=False, vad=found.to_json())
        click.echo(json.dumps(out, indent=2))
        return
    click.echo(tr.text)
    if nbest > 1:
        for i, h in enumerate(tr.nbest, 1):
            click.echo(f"{i:>3}  {h.score:10.2f}  {h.text}")
    click.echo(f"({tr.engine}, {tr.audio_s:.2f} s audio, RTF {tr.rtf:.3f})", err=True)


@click.command("voices")
@click.option("--json", "as_json", is_flag=True, help="print JSON")
def voices_cmd(as_json: bool) -> None:
    """List the TTS voices (names accepted by --voice)."""
    from siftom.speech.tts import engine_available, list_voices

    voices = list_voices()
    if as_json:
        out = [dict(v.to_json(), available=engine_available(v.engine)) for v in voices]
        click.echo(json.dumps(out, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    t = Table(title="siftom voices")
    for col in ("name", "engine", "accent", "gender", "installed", "description"):
        t.add_column(col)
    for v in voices:
        t.add_row(v.name, v.engine, v.accent, v.gender, "yes" if engine_available(v.engine) else "no",
                  v.description)
    Console().print(t)


@click.command("asr")
@click.option("--json", "as_json", is_flag=True, help="print the results as JSON")
@click.option("--out", "out_dir", default="bench-out/asr", show_default=True, help="folder for JSON + PNG")
@click.option("--quick", is_flag=True, help="2 voices, clean and 10 dB (under a minute)")
@click.option("--engine", "engines", multiple=True, help="engines (default: all registered pocketsphinx engines and whisper)")
@click.option("--voice", "voices", multiple=True, help="voices (default: 4 incl. one accented)")
@click.option("--noise", "noises", multiple=True, help="noise specs (default: babble)")
def bench_asr_cmd(as_json: bool, out_dir: str, quick: bool, engines: tuple[str, ...],
                  voices: tuple[str, ...], noises: tuple[str, ...]) -> None:
    """WER and real-time factor per engine x voice x noise x SNR on a fixed instruction set."""
    from siftom.bench import speech as b

    res = b.run_asr_bench(
        engines=engines or b.ENGINES,
        voices=voices or (b.QUICK_VOICES if quick else b.DEFAULT_VOICES),
        noises=noises or ("babble",),
        snrs=b.QUICK_SNRS if quick else b.DEFAULT_SNRS,
        progress=None if as_json else (lambda m: click.echo(f"  {m}", err=True)),
    )
    out = Path(out_dir)
    b.write_json(res.to_json(), out / "asr.json")
    png = b.plot_wer_vs_snr(res, out / "wer_vs_snr.png")
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    t = Table(title=f"siftom bench asr ({res.seconds:.0f} s)")
    for col in ("engine", "voice", "noise", "SNR dB", "WER %", "in-vocab %", "OOV %", "free %",
                "obj % gram", "obj % free", "RTF"):
        left = col in ("engine", "voice", "noise")
        t.add_column(col, justify="left" if left else "right", no_wrap=left)
    for r in res.rows:
        t.add_row(r.engine, r.voice, r.noise, "clean" if r.snr_db is None else f"{r.snr_db:g}",
                  f"{100 * r.wer:.0f}", f"{100 * r.wer_in_vocab:.0f}", f"{100 * r.wer_out_of_vocab:.0f}",
                  f"{100 * r.wer_free:.0f}", f"{100 * r.ower_grammar:.0f}", f"{100 * r.ower_free:.0f}",
                  f"{r.rtf:.3f}")
    c = Console()
    c.print(t)
    s = Table(title="mean WER % over voices")
    snr_cols = ["clean"] + [f"{x:g}" for x in (b.QUICK_SNRS if quick else b.DEFAULT_SNRS) if x is not None]
    s.add_column("engine")
    for col in snr_cols:
        s.add_column(col, justify="right")
    for e, by in b.summarise_wer(res).items():
        s.add_row(e, *[f"{100 * by[k]:.0f}" if k in by else "-" for k in snr_cols])
    c.print(s)
    for msg in res.skipped:
        click.echo(f"skipped {msg}", err=True)
    click.echo(f"wrote {out / 'asr.json'} and {png}")


@click.command("acoustic")
@click.option("--json", "as_json", is_flag=True, help="print the results as JSON")
@click.option("--out", "out_dir", default="bench-out/acoustic", show_default=True, help="folder for JSON")
@click.option("--quick", is_flag=True, help="2 voices, 1 template")
@click.option("--snr", type=float, default=None, help="mix noise at this SNR (default clean)")
@click.option("--noise", default="babble", show_default=True, help="noise spec used with --snr")
def bench_acoustic_cmd(as_json: bool, out_dir: str, quick: bool, snr: float | None, noise: str) -> None:
    """Accuracy of ranking the true phrasing first among swapped-object candidates, and cost."""
    from siftom.bench import speech as b

    res = b.run_acoustic_bench(
        voices=b.ACOUSTIC_VOICES[:2] if quick else b.ACOUSTIC_VOICES,
        templates=b.ACOUSTIC_TEMPLATES[:1] if quick else b.ACOUSTIC_TEMPLATES,
        snr_db=snr,
        noise=noise,
        progress=None if as_json else (lambda m: click.echo(f"  {m}", err=True)),
    )
    tag = "".join(c if c.isalnum() else "_" for c in Path(noise.split(":")[-1]).name)
    name = "acoustic_clean.json" if snr is None else f"acoustic_{tag}_snr{snr:g}.json"
    path = b.write_json(res.to_json(), Path(out_dir) / name)
    if as_json:
        click.echo(json.dumps(res.to_json(), indent=2))
        return
    cond = "clean" if snr is None else f"{noise} {snr:g} dB"
    click.echo(f"acoustic scorer ({cond}, {res.utterances} utterances x {res.candidates} candidates): "
               f"top-1 {100 * res.accuracy:.1f} %, {res.ms_per_candidate:.1f} ms per candidate")
    click.echo(f"baseline (biased-LM 1-best names the food): {100 * res.baseline_accuracy:.1f} %, "
               f"{res.baseline_ms:.1f} ms per utterance")
    click.echo(f"N-best phonetic likelihood (10-best of the same ASR): {100 * res.phonetic_accuracy:.1f} %, "
               f"{res.phonetic_ms:.1f} ms per utterance on top of the ASR")
    for v, a in res.by_voice.items():
        click.echo(f"  {v:<22} {100 * a:5.1f} %")
    if res.confusions:
        click.echo("  errors: " + ", ".join(f"{t}->{c}" for t, c in res.confusions[:12]))
    click.echo(f"wrote {path}")


def register(root: click.Group) -> None:
    """Add the speech commands to the root group (and to a shared ``bench`` group)."""
    root.add_command(say_cmd)
    root.add_command(transcribe_cmd)
    root.add_command(voices_cmd)
    from siftom.cli.bench import bench_group as bench

    bench.add_command(bench_asr_cmd)
    bench.add_command(bench_acoustic_cmd)
