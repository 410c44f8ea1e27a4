"""``siftom demo``: the main job end to end on the embedded default (paper, Figure 2).

kitchen-cereal-v0: the human has taken milk and a bowl. "Can you pass me the cereal" is
spoken by a synthetic voice, mixed with babble at 10 dB, transcribed offline with N-best, and
SIFToM infers the command from the words and what the human did; speech alone is shown too.
"""

from __future__ import annotations

import json
from pathlib import Path

import click
from rich.console import Console

from siftom.speech.cli_options import whisper_model_option


@click.command("demo")
@whisper_model_option
@click.option("--scenario", "scenario_id", default="kitchen-cereal-v0", show_default=True)
@click.option("--text", default="can you pass me the cereal", show_default=True, help="What the human says.")
@click.option("--voice", default="flite-slt", show_default=True, help="TTS voice (see `siftom voices`).")
@click.option("--noise", default="babble", show_default=True,
              help="Noise: babble, pink, white, brown, hum, or a WAV file/folder.")
@click.option("--snr", default=10.0, show_default=True, help="Signal-to-noise ratio in dB.")
@click.option("--seed", default=0, show_default=True)
@click.option("--likelihood", type=click.Choice(["acoustic", "phonetic"]), default="acoustic", show_default=True,
              help="acoustic: score the audio itself; phonetic: score the N-best transcripts.")
@click.option("--out", "out_dir", type=click.Path(path_type=Path), default=Path("siftom-demo"), show_default=True)
def demo_cmd(scenario_id: str, text: str, voice: str, noise: str, snr: float, seed: int, likelihood: str,
             out_dir: Path) -> None:
    """Speak, add noise, transcribe, infer: the whole SIFToM chain on one scenario."""
    from siftom.api import get_model, make_instruction, transcribe_for
    from siftom.cli.inference import print_posterior
    from siftom.inference.model import Observation
    from siftom.scenarios.base import get_scenario
    from siftom.speech import get_noise, mix_at_snr, synthesize, write_wav
    from siftom.world.render import render_scenario

    con = Console()
    sc = get_scenario(scenario_id)
    con.rule(f"[bold]{sc.id}[/bold]")
    con.print(sc.description)
    con.print("the robot saw the human do:")
    for k, a in enumerate(sc.actions, 1):
        con.print(f"  {k:2d}. {sc.world.format_action(a)}")
    out_dir.mkdir(parents=True, exist_ok=True)
    clean = synthesize(text, voice)
    mixed = mix_at_snr(clean, get_noise(noise), snr, rng=seed)
    wav = write_wav(out_dir / "instruction.wav", mixed)
    con.print(f'\nthe human says "{text}" ({voice}), heard through {noise} noise at {snr:g} dB -> {wav}')
    tr = transcribe_for(wav, sc.world, sc.verb, "pocketsphinx")  # DEFAULT_NBEST hypotheses
    con.print(f'ASR 1-best: "[bold]{tr.text}[/bold]"   (N-best: {len(tr.nbest)}, real-time factor {tr.rtf:.2f})')
    for h in tr.nbest[:5]:
        con.print(f"    {h.score:8.2f}  {h.text}")
    nbest = [{"text": h.text, "score": h.score} for h in tr.nbest] or [{"text": tr.text or text, "score": 0.0}]
    instruction = make_instruction(nbest=nbest, audio=wav if likelihood == "acoustic" else None)
    literal = get_model("speech-only", "phonetic").infer(Observation.from_scenario(sc, make_instruction(nbest=nbest)))
    speech_only = get_model("speech-only", likelihood).infer(Observation.from_scenario(sc, instruction))
    post = get_model("full", likelihood).infer(Observation.from_scenario(sc, instruction))
    con.rule(f"SIFToM (what the human did + {'the audio' if likelihood == 'acoustic' else 'the N-best words'})")
    print_posterior(post, con)
    con.print(f"from the transcripts alone: {literal.command} (P={literal.commands[0][1]:.2f}); "
              f"from the {likelihood} likelihood alone: {speech_only.command} (P={speech_only.commands[0][1]:.2f})")
    con.print(f"SIFToM chooses [bold]{post.command}[/bold] (P={post.commands[0][1]:.2f}); the human meant {sc.command}")
    png = render_scenario(sc, out_dir / "demo.png", posterior=post)
    (out_dir / "posterior.json").write_text(json.dumps(post.to_json(), indent=2))
    con.print(f"\npicture: {png}   posterior: {out_dir / 'posterior.json'}")
    con.print("next: [bold]siftom serve[/bold] and open http://127.0.0.1:8000 for the browser demo; "
              "`siftom --help` lists everything.")


def register(root: click.Group) -> None:
    root.add_command(demo_cmd)
